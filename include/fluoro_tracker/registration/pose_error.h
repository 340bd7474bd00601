#pragma once

#include <string>
#include <vector>

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

// Accuracy of tracked poses against reference poses: a frame succeeds when all its bones meet
// the criterion; RMS per degree of freedom over every bone-frame.
class AccuracyTally {
 public:
  explicit AccuracyTally(const SuccessCriterion& criterion = kChapter3Criterion)
      : criterion_(criterion) {}
  void addFrame(const std::vector<PoseError>& bone_errors);
  int frames() const { return frames_; }
  int framesWithin() const { return frames_within_; }
  // tx, ty, tz (mm), rx, ry, rz (deg); zero before any bone-frame.
  Eigen::Matrix<double, 6, 1> rms() const;
  // "N/M frames within 1 mm in-plane, 2 deg about X and Z, 3 deg about Y; RMS tx ... deg".
  std::string summary() const;

 private:
  SuccessCriterion criterion_;
  int frames_ = 0;
  int frames_within_ = 0;
  int bone_frames_ = 0;
  Eigen::Matrix<double, 6, 1> sum_squares_ = Eigen::Matrix<double, 6, 1>::Zero();
};

}  // namespace registration
}  // namespace fluoro_tracker
