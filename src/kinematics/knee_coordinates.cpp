#include "fluoro_tracker/kinematics/knee_coordinates.h"

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace kinematics {

Side sideFromName(const std::string& name) {
  if (name == "right") return Side::kRight;
  if (name == "left") return Side::kLeft;
  throw InputError("side '" + name + "' is not right or left");
}

std::string sideName(Side side) {
  return side == Side::kRight ? "right" : "left";
}

KneeCoordinates kneeCoordinates(const geometry::Pose& femur, const geometry::Pose& tibia,
                                Side side) {
  const geometry::Pose relative = femur.inverse() * tibia;
  const Eigen::Matrix3d r = relative.linear();
  const Eigen::Vector3d t = relative.translation();
  double q[6];
  kneeCoordinatesInFemurFrame<double>(r, t, side, q);
  return {q[0], q[1], q[2], q[3], q[4], q[5]};
}

geometry::Pose tibiaFromKneeCoordinates(const geometry::Pose& femur, const KneeCoordinates& c,
                                        Side side) {
  const double sign = side == Side::kRight ? 1.0 : -1.0;
  const Eigen::Matrix3d r = geometry::rotationZ(-c.flexion_rad) *
                            geometry::rotationX(sign * c.adduction_rad) *
                            geometry::rotationY(sign * c.internal_rotation_rad);
  const Eigen::Vector3d e1 = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d e3 = r.col(1);
  const Eigen::Vector3d e2 = e3.cross(e1).normalized();
  const Eigen::Vector3d t = c.x_m * e2 + c.y_m * e3 + sign * c.z_m * e1;
  return femur * geometry::makePose(r, t);
}

}  // namespace kinematics
}  // namespace fluoro_tracker
