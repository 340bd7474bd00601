#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

namespace fluoro_tracker {
namespace io {

// Parses a YAML file. Throws InputError "<what> '<path>' ..." for a missing file, a syntax error
// (with its line) or an unreadable file, so every YAML input reports problems the same way.
YAML::Node loadYamlFile(const std::string& path, const std::string& what);

}  // namespace io
}  // namespace fluoro_tracker
