#include "fluoro_tracker/registration/pose_error.h"

#include <cmath>

namespace fluoro_tracker {
namespace registration {

PoseError poseError(const geometry::Pose& estimate, const geometry::Pose& truth,
                    const geometry::Pose& camera_from_fixed) {
  PoseError e;
  e.translation_mm =
      1e3 * camera_from_fixed.linear() * (estimate.translation() - truth.translation());
  const Eigen::AngleAxisd delta(truth.linear().transpose() * estimate.linear());
  e.rotation_deg = geometry::radToDeg(delta.angle()) * delta.axis();
  return e;
}

bool meetsSuccessCriterion(const PoseError& e, const SuccessCriterion& c) {
  return std::abs(e.translation_mm.x()) <= c.in_plane_mm &&
         std::abs(e.translation_mm.y()) <= c.in_plane_mm &&
         std::abs(e.rotation_deg.x()) <= c.xz_deg && std::abs(e.rotation_deg.z()) <= c.xz_deg &&
         std::abs(e.rotation_deg.y()) <= c.y_deg;
}

}  // namespace registration
}  // namespace fluoro_tracker
