#include "fluoro_tracker/io/yaml_file.h"

#include <filesystem>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace io {

YAML::Node loadYamlFile(const std::string& path, const std::string& what) {
  if (!std::filesystem::exists(path)) throw InputError(what + " '" + path + "' does not exist");
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::ParserException& e) {
    throw InputError(what + " '" + path + "' is not valid YAML (line " +
                     std::to_string(e.mark.line + 1) + "): " + e.msg);
  } catch (const YAML::Exception& e) {
    throw InputError(what + " '" + path + "' cannot be read: " + e.what());
  }
}

}  // namespace io
}  // namespace fluoro_tracker
