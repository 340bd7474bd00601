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

}  // namespace registration
}  // namespace fluoro_tracker
