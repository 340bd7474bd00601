#pragma once

#include <Eigen/Core>

#include "fluoro_tracker/geometry/pose.h"

namespace fluoro_tracker {
namespace registration {

// The registration's per-bone unknown: a 6-vector [w, t] that moves a bone from its current
// pose T0 (in the fixed frame) by a rotation R(w) (axis-angle) about the centre c and a
// translation t: a point p0 = T0·X goes to R(w)·(p0 − c) + c + t. Rotating about the bone's
// centre rather than the frame origin decouples rotation from translation.
geometry::Pose applyIncrement(const geometry::Pose& pose, const Eigen::Vector3d& centre,
                              const double* increment);

// Left Jacobian of SO(3): d/dw [R(w)·v] = −[R(w)·v]× · J(w).
Eigen::Matrix3d so3LeftJacobian(const Eigen::Vector3d& w);

}  // namespace registration
}  // namespace fluoro_tracker
