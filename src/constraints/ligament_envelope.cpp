#include "fluoro_tracker/constraints/ligament_envelope.h"

#include <cmath>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace constraints {

const std::array<const char*, 6>& LigamentSettings::coordinateNames() {
  static const std::array<const char*, 6> names = {
      "flexion_deg", "adduction_deg", "internal_rotation_deg", "x_mm", "y_mm", "z_mm"};
  return names;
}

void LigamentSettings::validate() const {
  for (int k = 0; k < 6; ++k) {
    if (std::isnan(bounds[k].lower) || std::isnan(bounds[k].upper) ||
        !(bounds[k].lower <= bounds[k].upper)) {
      throw InputError(std::string("ligaments: ") + coordinateNames()[k] + " needs lower <= upper");
    }
  }
  if (!(stiffness_per_deg >= 0.0) || !(stiffness_per_mm >= 0.0)) {
    throw InputError("ligaments: stiffness_per_deg and stiffness_per_mm must be >= 0");
  }
  for (std::size_t i = 0; i < bundles.size(); ++i) {
    bundles[i].validate();
    for (std::size_t j = 0; j < i; ++j) {
      if (bundles[j].name == bundles[i].name) {
        throw InputError("ligaments: two bundles are named '" + bundles[i].name + "'");
      }
    }
  }
}

}  // namespace constraints
}  // namespace fluoro_tracker
