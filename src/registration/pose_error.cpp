#include "fluoro_tracker/registration/pose_error.h"

#include <cmath>
#include <iomanip>
#include <sstream>

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

void AccuracyTally::addFrame(const std::vector<PoseError>& bone_errors) {
  bool within = true;
  for (const PoseError& e : bone_errors) {
    Eigen::Matrix<double, 6, 1> dofs;
    dofs << e.translation_mm, e.rotation_deg;
    sum_squares_ += dofs.cwiseProduct(dofs);
    ++bone_frames_;
    within = within && meetsSuccessCriterion(e, criterion_);
  }
  ++frames_;
  frames_within_ += within ? 1 : 0;
}

Eigen::Matrix<double, 6, 1> AccuracyTally::rms() const {
  if (bone_frames_ == 0) return Eigen::Matrix<double, 6, 1>::Zero();
  return (sum_squares_ / bone_frames_).cwiseSqrt();
}

std::string AccuracyTally::summary() const {
  const Eigen::Matrix<double, 6, 1> r = rms();
  std::ostringstream out;
  out << frames_within_ << "/" << frames_ << " frames within " << criterion_.in_plane_mm
      << " mm in-plane, " << criterion_.xz_deg << " deg about X and Z, " << criterion_.y_deg
      << " deg about Y; RMS" << std::fixed << std::setprecision(2) << " tx " << r[0] << " mm, ty "
      << r[1] << " mm, tz (along the beam) " << r[2] << " mm, rx " << r[3] << " deg, ry " << r[4]
      << " deg, rz " << r[5] << " deg";
  return out.str();
}

}  // namespace registration
}  // namespace fluoro_tracker
