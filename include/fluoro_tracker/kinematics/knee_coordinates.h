#pragma once

#include <cmath>
#include <string>

#include <Eigen/Core>

#include "fluoro_tracker/geometry/pose.h"

namespace fluoro_tracker {
namespace kinematics {

enum class Side { kRight, kLeft };
Side sideFromName(const std::string& name);  // "right" | "left"; throws InputError
std::string sideName(Side side);

// The knee's six joint coordinates (Grood & Suntay 1983, as recommended by the ISB), from the
// femur's and tibia's anatomical frames (ISB: X anterior, Y superior, Z to the right):
//   e1, the flexion axis, is the femur's Z; e3, the rotation axis, is the tibia's Y; e2, the
//   floating axis, is e3 x e1 (anterior when the knee is straight).
//   flexion: about e1, positive when the tibia swings posteriorly (knee bends);
//   adduction: about e2, positive for varus (the distal tibia moves medially);
//   internal rotation: about e3, positive when the tibia's front turns medially.
//   x, y, z: the tibia frame's origin relative to the femur frame's, as components along e2
//   (anterior), e3 (superior, i.e. distraction) and e1 (lateral, whichever the side).
// Equivalently the tibia's orientation in the femur frame is Rz(a) Rx(b) Ry(g) with
// a = -flexion and, for a right knee, b = adduction, g = internal rotation (both negated for a
// left knee, whose Z points medially). Signs are the same clinical ones on both sides.
struct KneeCoordinates {
  double flexion_rad = 0.0;
  double adduction_rad = 0.0;
  double internal_rotation_rad = 0.0;
  double x_m = 0.0;  // anterior
  double y_m = 0.0;  // superior (distraction)
  double z_m = 0.0;  // lateral
};

// Coordinates from the two anatomical frames' poses (any common frame).
KneeCoordinates kneeCoordinates(const geometry::Pose& femur, const geometry::Pose& tibia,
                                Side side);
// The tibia's anatomical frame for given coordinates: the exact inverse of kneeCoordinates.
geometry::Pose tibiaFromKneeCoordinates(const geometry::Pose& femur,
                                        const KneeCoordinates& coordinates, Side side);

// The same computation on any scalar type (Ceres Jets in the ligament cost): tibia rotation and
// origin in the femur's frame -> {flexion, adduction, internal rotation (rad), x, y, z (m)}.
template <typename T>
void kneeCoordinatesInFemurFrame(const Eigen::Matrix<T, 3, 3>& r, const Eigen::Matrix<T, 3, 1>& t,
                                 Side side, T out[6]) {
  using std::asin;
  using std::atan2;
  using std::max;
  using std::min;
  // r = Rz(a) Rx(b) Ry(g): r(2,1) = sin b, r(0,1) = -sin a cos b, r(1,1) = cos a cos b,
  // r(2,0) = -cos b sin g, r(2,2) = cos b cos g.
  const T sb = min(T(1.0), max(T(-1.0), r(2, 1)));
  const T a = atan2(-r(0, 1), r(1, 1));
  const T b = asin(sb);
  const T g = atan2(-r(2, 0), r(2, 2));
  const T sign = T(side == Side::kRight ? 1.0 : -1.0);
  out[0] = -a;
  out[1] = sign * b;
  out[2] = sign * g;
  // t = x e2 + y e3 + z' e1 with e1 = Z, e3 = r's Y column, e2 = e3 x e1 / |e3 x e1|.
  const Eigen::Matrix<T, 3, 1> e1(T(0.0), T(0.0), T(1.0));
  const Eigen::Matrix<T, 3, 1> e3 = r.col(1);
  Eigen::Matrix<T, 3, 1> e2 = e3.cross(e1);
  e2 /= e2.norm();
  Eigen::Matrix<T, 3, 3> basis;
  basis.col(0) = e2;
  basis.col(1) = e3;
  basis.col(2) = e1;
  const Eigen::Matrix<T, 3, 1> q = basis.inverse() * t;
  out[3] = q(0);
  out[4] = q(1);
  out[5] = sign * q(2);
}

}  // namespace kinematics
}  // namespace fluoro_tracker
