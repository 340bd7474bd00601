#pragma once

#include <cmath>

#include <Eigen/Core>

#include "fluoro_tracker/kinematics/knee_coordinates.h"

namespace fluoro_tracker {
namespace kinematics {

// The humerus' rotation and origin in the scapula frame as a right shoulder's: a left one's
// mirrored through the sagittal (X-Y) plane (joint_types.h: the left side mirrors the right).
template <typename T>
void glenohumeralAsRight(Side side, Eigen::Matrix<T, 3, 3>* r, Eigen::Matrix<T, 3, 1>* t) {
  if (side == Side::kRight) return;
  const Eigen::Matrix<T, 3, 1> mirror(T(1.0), T(1.0), T(-1.0));
  *r = mirror.asDiagonal() * *r * mirror.asDiagonal();
  *t = mirror.asDiagonal() * *t;
}

// The glenohumeral joint's coordinates (ISB Y-X-Y, joint_types.h) on any scalar type (Ceres Jets
// in the ligament cost), from a right shoulder's humerus rotation r and origin t in the scapula
// frame: {plane of elevation, elevation, axial rotation (rad), x, y, z (m)}. With
// r = Ry(a) Rx(b) Ry(g): r(1,1) = cos b, r(0,1) = sin a sin b, r(2,1) = cos a sin b,
// r(1,0) = sin b sin g, r(1,2) = -sin b cos g; b is taken in [-pi, 0]. Where the first and third
// axes are one to machine precision (b = 0 or -pi), a = 0 and all of the turn is g.
template <typename T>
void glenohumeralCoordinatesInScapulaFrame(const Eigen::Matrix<T, 3, 3>& r,
                                           const Eigen::Matrix<T, 3, 1>& t, T out[6]) {
  using std::atan2;
  using std::sqrt;
  const T sin_b_squared = r(0, 1) * r(0, 1) + r(2, 1) * r(2, 1);
  if (sin_b_squared > T(1e-24)) {
    out[0] = atan2(-r(0, 1), -r(2, 1));
    out[1] = atan2(-sqrt(sin_b_squared), r(1, 1));
    out[2] = atan2(-r(1, 0), r(1, 2));
  } else {
    // r = Ry(g) (b = 0) or Rx(-pi) Ry(g) (b = -pi): r(0,0) = cos g, r(0,2) = sin g.
    out[0] = T(0.0);
    out[1] = atan2(T(-0.0), r(1, 1));
    out[2] = atan2(r(0, 2), r(0, 0));
  }
  out[3] = t(0);
  out[4] = t(1);
  out[5] = t(2);
}

}  // namespace kinematics
}  // namespace fluoro_tracker
