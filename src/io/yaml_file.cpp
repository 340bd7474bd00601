#include "fluoro_tracker/io/yaml_file.h"

#include <cmath>
#include <filesystem>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace io {

std::string resolvePath(const std::string& base_folder, const std::string& path) {
  const std::filesystem::path p(path);
  return (p.is_absolute() ? p : (std::filesystem::path(base_folder) / p))
      .lexically_normal()
      .string();
}

std::vector<double> numberList(const YAML::Node& node, const std::string& key, std::size_t size,
                               const std::string& context) {
  const auto values = required<std::vector<double>>(node, key, context);
  if (values.size() != size) {
    throw InputError(context + ": '" + key + "' must have " + std::to_string(size) +
                     " numbers, has " + std::to_string(values.size()));
  }
  for (double v : values) {
    if (!std::isfinite(v)) throw InputError(context + ": '" + key + "' has a non-finite value");
  }
  return values;
}

geometry::Pose readYamlPose(const YAML::Node& pose, const std::string& context) {
  const auto p = numberList(pose, "position_m", 3, context);
  const auto q = numberList(pose, "orientation_xyzw", 4, context);
  const Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
  if (std::abs(rotation.norm() - 1.0) > 1e-3) {
    throw InputError(context + ": orientation_xyzw is not a unit quaternion");
  }
  return geometry::makePose(rotation.normalized(), Eigen::Vector3d(p[0], p[1], p[2]));
}

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
