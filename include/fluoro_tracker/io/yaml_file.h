#pragma once

#include <initializer_list>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace io {

// Parses a YAML file. Throws InputError "<what> '<path>' ..." for a missing file, a syntax error
// (with its line) or an unreadable file, so every YAML input reports problems the same way.
YAML::Node loadYamlFile(const std::string& path, const std::string& what);

// `path` as written in a YAML file whose folder is `base_folder`: relative paths are relative to
// that folder.
std::string resolvePath(const std::string& base_folder, const std::string& path);

// The value of a key that must be present. Throws InputError naming `context` and the key (and
// its line) when it is missing or of the wrong type.
template <typename T>
T required(const YAML::Node& node, const std::string& key, const std::string& context) {
  const YAML::Node value = node[key];
  if (!value) throw InputError(context + ": missing key '" + key + "'");
  try {
    return value.as<T>();
  } catch (const YAML::Exception&) {
    throw InputError(context + ": key '" + key + "' (line " +
                     std::to_string(value.Mark().line + 1) + ") has the wrong type");
  }
}

// A required list of exactly `size` finite numbers.
std::vector<double> numberList(const YAML::Node& node, const std::string& key, std::size_t size,
                               const std::string& context);

// {position_m: [x, y, z], orientation_xyzw: [x, y, z, w]}, metres and a unit quaternion.
geometry::Pose readYamlPose(const YAML::Node& pose, const std::string& context);

// A map in a YAML document, read into typed fields with errors that name the section, key and
// line. Missing keys leave fields at their defaults; unknown keys can be rejected.
class YamlSection {
 public:
  YamlSection(const YAML::Node& node, std::string context)
      : node_(node), context_(std::move(context)) {
    if (node_ && !node_.IsMap()) throw InputError(context_ + " must be a map");
  }

  template <typename T>
  void read(const std::string& key, T* value) const {
    if (!node_) return;
    const YAML::Node v = node_[key];
    if (!v) return;
    try {
      *value = v.as<T>();
    } catch (const YAML::Exception&) {
      throw InputError(context_ + "." + key + " (line " + std::to_string(v.Mark().line + 1) +
                       ") has the wrong type");
    }
  }

  YamlSection child(const std::string& key) const {
    return YamlSection(node_ ? node_[key] : YAML::Node(), context_ + "." + key);
  }

  // Rejects keys this reader does not know, so a typo is not silently ignored.
  void allowOnly(std::initializer_list<const char*> keys) const {
    if (!node_) return;
    for (const auto& entry : node_) {
      const std::string key = entry.first.as<std::string>();
      bool known = false;
      for (const char* k : keys) known = known || key == k;
      if (!known) throw InputError(context_ + ": unknown key '" + key + "'");
    }
  }

 private:
  YAML::Node node_;
  std::string context_;
};

}  // namespace io
}  // namespace fluoro_tracker
