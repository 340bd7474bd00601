#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "fluoro_tracker/constraints/ligament_bundle.h"

namespace fluoro_tracker {
namespace constraints {

// Lower and upper bound of one joint coordinate; infinite for none.
struct CoordinateBounds {
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
};

// Ligament-like springs (dissertation ch. 4): each of a joint's six coordinates (kinematics::
// KneeCoordinates, in degrees and millimetres) may move freely within its bounds; outside, a
// spring pulls it back with a residual of stiffness x distance outside. Knee defaults from the
// dissertation: 10 deg hyperextension to 150 deg flexion, varus-valgus +-3 deg, internal-external
// +-20 deg, femur 30 mm posterior to 10 mm anterior of the tibia (the tibia -10..30 mm anterior
// of the femur), medial-lateral +-5 mm; distraction free. The translations' zero is where the
// two frames' origins coincide, so bounds on them only make sense for meshes whose origins sit
// at the joint centre (or with anatomical frames given in the trial YAML).
struct LigamentSettings {
  bool enabled = true;
  // flexion_deg, adduction_deg, internal_rotation_deg, x_mm, y_mm, z_mm
  std::array<CoordinateBounds, 6> bounds = {
      {{-10.0, 150.0}, {-3.0, 3.0}, {-20.0, 20.0}, {-10.0, 30.0}, {}, {-5.0, 5.0}}};
  double stiffness_per_deg = 10.0;  // residual per degree outside the bounds
  double stiffness_per_mm = 10.0;   // residual per millimetre outside the bounds
  // Ligaments between insertion points (none by default: where they insert depends on the
  // bones or implants); they act with the coordinate springs, when enabled.
  std::vector<LigamentBundle> bundles;

  static const std::array<const char*, 6>& coordinateNames();
  void validate() const;  // throws InputError naming the field
};

// The six spring residuals from coordinates in radians and metres (any scalar type).
template <typename T>
void ligamentResiduals(const LigamentSettings& s, const T coordinates[6], T residuals[6]) {
  constexpr double kDegPerRad = 57.29577951308232;
  for (int k = 0; k < 6; ++k) {
    const T value = k < 3 ? coordinates[k] * kDegPerRad : coordinates[k] * 1000.0;
    const double stiffness = k < 3 ? s.stiffness_per_deg : s.stiffness_per_mm;
    if (value > s.bounds[k].upper) {
      residuals[k] = stiffness * (value - s.bounds[k].upper);
    } else if (value < s.bounds[k].lower) {
      residuals[k] = stiffness * (value - s.bounds[k].lower);
    } else {
      residuals[k] = T(0.0);
    }
  }
}

// The largest distance of a coordinate outside its bounds (degrees or millimetres; 0 inside):
// the largest |residual| that `springs(unit, residuals)` writes with `unit` the settings at
// stiffness 1, whichever coordinates the springs act on.
template <typename Springs>
double largestExcess(const LigamentSettings& settings, Springs springs) {
  LigamentSettings unit = settings;
  unit.stiffness_per_deg = 1.0;
  unit.stiffness_per_mm = 1.0;
  double residuals[6];
  springs(unit, residuals);
  double worst = 0.0;
  for (double r : residuals) worst = std::max(worst, std::abs(r));
  return worst;
}

}  // namespace constraints
}  // namespace fluoro_tracker
