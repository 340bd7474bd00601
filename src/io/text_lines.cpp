#include "text_lines.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace io {
namespace detail {

std::string trim(const std::string& text) {
  const auto begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  const auto end = text.find_last_not_of(" \t\r\n");
  return text.substr(begin, end - begin + 1);
}

std::vector<std::string> readTrimmedLines(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw InputError(what + " '" + path + "' cannot be opened (missing or unreadable)");
  std::vector<std::string> lines;
  std::string line;
  bool any_content = false;
  while (std::getline(in, line)) {
    lines.push_back(trim(line));
    if (!lines.back().empty()) any_content = true;
  }
  if (!any_content) throw InputError(what + " '" + path + "' is empty");
  return lines;
}

std::vector<double> parseNumbers(const std::string& line, int expected,
                                 const std::string& context) {
  std::string spaced = line;
  for (char& c : spaced) {
    if (c == ',' || c == ';' || c == '\t') c = ' ';
  }
  std::istringstream in(spaced);
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0' || !std::isfinite(value)) {
      throw InputError(context + ": '" + token + "' is not a finite number");
    }
    values.push_back(value);
  }
  if (expected >= 0 && static_cast<int>(values.size()) != expected) {
    throw InputError(context + ": expected " + std::to_string(expected) + " number(s), found " +
                     std::to_string(values.size()) + " in '" + line + "'");
  }
  return values;
}

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string field;
  while (std::getline(in, field, ',')) fields.push_back(trim(field));
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

bool isTrackingStatus(const std::string& status) {
  return status == "ok" || status == "suspect" || status == "lost";
}

void requireHeader(const std::vector<std::string>& lines, const std::string& expected,
                   const std::string& what, const std::string& path) {
  if (lines[0].rfind(expected, 0) != 0) {
    throw InputError(what + " '" + path + "': header must start with '" + expected + "', found '" +
                     lines[0] + "'");
  }
}

int parseFrameIndex(const std::string& field, const std::string& context) {
  const double frame = parseNumbers(field, 1, context + " column 1")[0];
  if (frame < 0 || frame != std::floor(frame)) {
    throw InputError(context + ": frame must be a whole number >= 0");
  }
  return static_cast<int>(frame);
}

}  // namespace detail
}  // namespace io
}  // namespace fluoro_tracker
