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

// A success criterion for one bone: limits on each in-plane translation, on the rotation about
// X and Z, and about Y (the long axis).
struct SuccessCriterion {
  double in_plane_mm = 1.0;
  double xz_deg = 2.0;
  double y_deg = 3.0;
};
// Chapter 3's criterion (the default) and chapter 4's looser one for crude starts.
constexpr SuccessCriterion kChapter3Criterion{1.0, 2.0, 3.0};
constexpr SuccessCriterion kChapter4Criterion{1.5, 3.0, 5.0};

bool meetsSuccessCriterion(const PoseError& error,
                           const SuccessCriterion& criterion = kChapter3Criterion);

}  // namespace registration
}  // namespace fluoro_tracker
