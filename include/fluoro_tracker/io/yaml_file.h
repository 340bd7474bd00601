#pragma once

#include <initializer_list>
#include <string>

#include <yaml-cpp/yaml.h>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace io {

// Parses a YAML file. Throws InputError "<what> '<path>' ..." for a missing file, a syntax error
// (with its line) or an unreadable file, so every YAML input reports problems the same way.
YAML::Node loadYamlFile(const std::string& path, const std::string& what);

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
