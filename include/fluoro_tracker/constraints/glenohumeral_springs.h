#pragma once

#include <cmath>

#include <Eigen/Core>

#include "fluoro_tracker/constraints/ligament_envelope.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/kinematics/glenohumeral_angles.h"

namespace fluoro_tracker {
namespace constraints {

// Ligament-like springs of a glenohumeral joint: LigamentSettings' bounds on its own coordinates
// (plane of elevation, elevation, axial rotation in degrees; x, y, z in mm; joint_types.h), the
// same linear springs outside them as every joint's (ligamentResiduals). The ISB's Y-X-Y angles
// are singular where the humerus' long axis meets the scapula's Y (the arm along the trunk,
// elevation 0): there the plane of elevation is undefined and jumps as the arm passes through,
// while the plane plus the axial rotation (the whole turn, which the ISB reports as axial
// rotation) stays smooth. So that the springs stay smooth there too, with
// w = sin^2(elevation) / (sin^2(elevation) + sin^2(2 deg)):
//   - the plane of elevation's spring is scaled by w (it fades within a few degrees of the pole);
//   - the axial rotation's spring acts on axial rotation + (1 - w) x plane of elevation (wrapped
//     to +-180 deg): the reported axial rotation away from the pole (within 0.5 deg beyond 30 deg
//     of elevation for a plane within +-90 deg), the whole turn at it.
// Any scalar type (Ceres Jets in the ligament cost). r, t: the humerus' rotation and origin in
// the scapula frame, as a right shoulder's (kinematics::glenohumeralAsRight).
template <typename T>
void glenohumeralSpringResiduals(const LigamentSettings& settings, const Eigen::Matrix<T, 3, 3>& r,
                                 const Eigen::Matrix<T, 3, 1>& t, T residuals[6]) {
  using std::atan2;
  using std::cos;
  using std::sin;
  T coordinates[6];
  kinematics::glenohumeralCoordinatesInScapulaFrame(r, t, coordinates);
  const T sin_squared = r(0, 1) * r(0, 1) + r(2, 1) * r(2, 1);  // sin^2(elevation)
  const double pole = std::sin(2.0 * M_PI / 180.0);
  const T w = sin_squared / (sin_squared + T(pole * pole));
  // Wrapped to (-pi, pi], as the reported angle is.
  const T turn = coordinates[2] + (T(1.0) - w) * coordinates[0];
  coordinates[2] = atan2(sin(turn), cos(turn));
  ligamentResiduals(settings, coordinates, residuals);
  residuals[0] *= w;
}

// The largest of a glenohumeral joint's distances outside its bounds (degrees or millimetres,
// the springs' residuals at unit stiffness; 0 inside), from the scapula's and humerus'
// anatomical frames (any common frame).
double glenohumeralEnvelopeViolation(const LigamentSettings& settings,
                                     const geometry::Pose& scapula, const geometry::Pose& humerus,
                                     kinematics::Side side);

}  // namespace constraints
}  // namespace fluoro_tracker
