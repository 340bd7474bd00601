#include "fluoro_tracker/registration/pose_increment.h"

#include <cmath>

namespace fluoro_tracker {
namespace registration {

geometry::Pose applyIncrement(const geometry::Pose& pose, const Eigen::Vector3d& centre,
                              const double* increment) {
  const Eigen::Vector3d w(increment[0], increment[1], increment[2]);
  const Eigen::Vector3d t(increment[3], increment[4], increment[5]);
  const double angle = w.norm();
  const Eigen::Matrix3d r = angle > 0.0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                                        : Eigen::Matrix3d::Identity();
  geometry::Pose out = pose;
  out.linear() = r * pose.linear();
  out.translation() = r * (pose.translation() - centre) + centre + t;
  return geometry::normalized(out);
}

Eigen::Matrix3d so3LeftJacobian(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  Eigen::Matrix3d k;
  k << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  if (angle < 1e-8) return Eigen::Matrix3d::Identity() + 0.5 * k;
  const double a2 = angle * angle;
  return Eigen::Matrix3d::Identity() + (1.0 - std::cos(angle)) / a2 * k +
         (angle - std::sin(angle)) / (a2 * angle) * k * k;
}

IncrementedPoints::IncrementedPoints(const double* increment, const Eigen::Vector3d& centre,
                                     const geometry::Pose& camera_from_fixed)
    : translation_(increment[3], increment[4], increment[5]),
      centre_(centre),
      camera_rotation_(camera_from_fixed.linear()),
      camera_translation_(camera_from_fixed.translation()) {
  const Eigen::Vector3d w(increment[0], increment[1], increment[2]);
  const double angle = w.norm();
  rotation_ = angle > 0.0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                          : Eigen::Matrix3d::Identity();
  left_jacobian_ = so3LeftJacobian(w);
}

Eigen::Vector3d IncrementedPoints::toCamera(const Eigen::Vector3d& q_fixed,
                                            Eigen::Vector3d* rotated) const {
  *rotated = rotation_ * (q_fixed - centre_);
  return camera_rotation_ * (*rotated + centre_ + translation_) + camera_translation_;
}

void IncrementedPoints::chain(const Eigen::RowVector3d& d_camera_point,
                              const Eigen::Vector3d& rotated, double* row) const {
  const Eigen::RowVector3d d_fixed = d_camera_point * camera_rotation_;
  Eigen::Matrix3d skew;
  skew << 0, -rotated.z(), rotated.y(), rotated.z(), 0, -rotated.x(), -rotated.y(), rotated.x(), 0;
  const Eigen::RowVector3d d_w = -d_fixed * skew * left_jacobian_;
  for (int k = 0; k < 3; ++k) {
    row[k] = d_w[k];
    row[3 + k] = d_fixed[k];
  }
}

}  // namespace registration
}  // namespace fluoro_tracker
