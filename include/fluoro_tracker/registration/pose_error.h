#pragma once

#include <Eigen/Core>

#include "fluoro_tracker/geometry/pose.h"

namespace fluoro_tracker {
namespace registration {

// Error of an estimated bone pose against a reference, as the dissertation reports it.
struct PoseError {
  Eigen::Vector3d translation_mm;  // x, y in-plane, z along the beam (a view's optical frame)
  Eigen::Vector3d rotation_deg;    // rotation vector of truth^-1 * estimate, bone X, Y, Z axes
};

// Both poses in the fixed frame; `camera_from_fixed` is the view whose axes define in-plane.
PoseError poseError(const geometry::Pose& estimate, const geometry::Pose& truth,
                    const geometry::Pose& camera_from_fixed);

// The dissertation's success criterion for one bone (chapter 3): at most 1 mm in-plane
// translation, 2 deg about X and Z, 3 deg about Y (the long axis).
bool meetsSuccessCriterion(const PoseError& error);

}  // namespace registration
}  // namespace fluoro_tracker
