#include "fluoro_tracker/registration/pose_increment.h"

#include <cmath>

namespace fluoro_tracker {
namespace registration {

Eigen::Matrix3d rotationFromAxisAngle(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  return angle > 0.0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                     : Eigen::Matrix3d::Identity();
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

geometry::Pose applyIncrement(const geometry::Pose& pose, const Eigen::Vector3d& centre,
                              const double* increment) {
  const Eigen::Vector3d w(increment[0], increment[1], increment[2]);
  const Eigen::Vector3d t(increment[3], increment[4], increment[5]);
  const Eigen::Matrix3d r = rotationFromAxisAngle(w);
  geometry::Pose out = pose;
  out.linear() = r * pose.linear();
  out.translation() = r * (pose.translation() - centre) + centre + t;
  return geometry::normalized(out);
}

Eigen::Matrix3d so3LeftJacobian(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  const Eigen::Matrix3d k = skew(w);
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
  rotation_ = rotationFromAxisAngle(w);
  left_jacobian_ = so3LeftJacobian(w);
}

}  // namespace registration
}  // namespace fluoro_tracker
