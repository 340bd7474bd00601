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

// R(w): the rotation of axis-angle vector w (identity for w = 0).
Eigen::Matrix3d rotationFromAxisAngle(const Eigen::Vector3d& w);

// [v]×: the cross-product matrix, [v]× u = v × u.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);

// Left Jacobian of SO(3): d/dw [R(w)·v] = −[R(w)·v]× · J(w).
Eigen::Matrix3d so3LeftJacobian(const Eigen::Vector3d& w);

// Moves fixed-frame points by one increment into a view's optical frame, and chains a
// derivative with respect to that camera-frame point back to the increment. Shared by every
// image cost; built once per evaluation.
class IncrementedPoints {
 public:
  IncrementedPoints(const double* increment, const Eigen::Vector3d& centre,
                    const geometry::Pose& camera_from_fixed);

  // The moved point in the optical frame; `rotated` receives R(w)·(q − c), which the
  // Jacobian needs. (Inline, as chain: both run once per residual in the hot loop.)
  Eigen::Vector3d toCamera(const Eigen::Vector3d& q_fixed, Eigen::Vector3d* rotated) const {
    *rotated = rotation_ * (q_fixed - centre_);
    return camera_rotation_ * (*rotated + centre_ + translation_) + camera_translation_;
  }
  // row[0..5] = d(value)/d(increment), given d(value)/d(camera point).
  void chain(const Eigen::RowVector3d& d_camera_point, const Eigen::Vector3d& rotated,
             double* row) const {
    const Eigen::Vector3d d_fixed = camera_rotation_.transpose() * d_camera_point.transpose();
    // d/dw of R(w)(q - c) is -skew(rotated) J_l(w), and a^T skew(r) = (a x r)^T.
    const Eigen::Vector3d d_w = left_jacobian_.transpose() * rotated.cross(d_fixed);
    for (int k = 0; k < 3; ++k) {
      row[k] = d_w[k];
      row[3 + k] = d_fixed[k];
    }
  }

 private:
  Eigen::Matrix3d rotation_;
  Eigen::Matrix3d left_jacobian_;
  Eigen::Vector3d translation_;
  Eigen::Vector3d centre_;
  Eigen::Matrix3d camera_rotation_;
  Eigen::Vector3d camera_translation_;
};

}  // namespace registration
}  // namespace fluoro_tracker
