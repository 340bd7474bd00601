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

bool meetsSuccessCriterion(const PoseError& e) {
  return std::abs(e.translation_mm.x()) <= 1.0 && std::abs(e.translation_mm.y()) <= 1.0 &&
         std::abs(e.rotation_deg.x()) <= 2.0 && std::abs(e.rotation_deg.z()) <= 2.0 &&
         std::abs(e.rotation_deg.y()) <= 3.0;
}

}  // namespace registration
}  // namespace fluoro_tracker
