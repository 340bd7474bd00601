#pragma once

#include <string>

namespace fluoro_tracker {
namespace geometry {

// Length unit of a file on disk. Everything inside the library is in metres (REP-103);
// files are converted when read and written.
enum class LengthUnit { kMillimetre, kMetre };

// Parses "mm" or "m"; throws InputError naming `context` for anything else.
LengthUnit parseLengthUnit(const std::string& text, const std::string& context);
std::string toString(LengthUnit unit);
double metresPerUnit(LengthUnit unit);

}  // namespace geometry
}  // namespace fluoro_tracker
