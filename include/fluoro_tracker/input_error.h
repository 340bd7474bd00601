#pragma once

#include <stdexcept>
#include <string>

namespace fluoro_tracker {

// Thrown for bad user input (files, parameters, messages). The message always names the
// offending input (a path, a key, a field) and what is wrong with it, so that a tool can print
// it as-is and a node can log it and keep running.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace fluoro_tracker
