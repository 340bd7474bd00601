#pragma once

// Small helpers shared by the line-oriented readers of io/ (JointTrack, MayaCam, CSV files).

#include <string>
#include <vector>

namespace fluoro_tracker {
namespace io {
namespace detail {

// All lines of a text file with trailing '\r' and surrounding blanks removed. Throws InputError
// if the file cannot be opened or is empty.
std::vector<std::string> readTrimmedLines(const std::string& path, const std::string& what);

// Parses numbers separated by commas and/or white space. Throws InputError naming `context`
// if a token is not a number or the count differs from `expected` (when expected >= 0).
std::vector<double> parseNumbers(const std::string& line, int expected, const std::string& context);

std::string trim(const std::string& text);
// Comma-separated fields, each trimmed; a trailing comma gives a trailing empty field.
std::vector<std::string> splitCsv(const std::string& line);
// A tracking status as the CSVs write it: ok, suspect or lost.
bool isTrackingStatus(const std::string& status);
// Throws InputError "<what> '<path>': header must start with ..." unless lines[0] starts with
// `expected`.
void requireHeader(const std::vector<std::string>& lines, const std::string& expected,
                   const std::string& what, const std::string& path);
// A CSV frame index: a whole number >= 0. Throws InputError naming `context` otherwise.
int parseFrameIndex(const std::string& field, const std::string& context);

}  // namespace detail
}  // namespace io
}  // namespace fluoro_tracker
