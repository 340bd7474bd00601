#include "fluoro_tracker/geometry/length_unit.h"

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace geometry {

LengthUnit parseLengthUnit(const std::string& text, const std::string& context) {
  if (text == "mm") return LengthUnit::kMillimetre;
  if (text == "m") return LengthUnit::kMetre;
  throw InputError(context + ": unknown length unit '" + text + "' (expected 'mm' or 'm')");
}

std::string toString(LengthUnit unit) {
  return unit == LengthUnit::kMillimetre ? "mm" : "m";
}

double metresPerUnit(LengthUnit unit) {
  return unit == LengthUnit::kMillimetre ? 1e-3 : 1.0;
}

}  // namespace geometry
}  // namespace fluoro_tracker
