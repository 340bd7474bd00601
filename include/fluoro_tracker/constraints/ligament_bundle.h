#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "fluoro_tracker/geometry/pose.h"

namespace fluoro_tracker {
namespace constraints {

// One ligament as a bundle between two insertion points, one on each bone of a joint (e.g. the
// collateral ligaments' origin on the femur and insertion on the tibia or fibula), each given in
// its bone's mesh frame. Slack up to its slack length; stretched beyond it, a spring pulls with
// a residual of stiffness x stretch (per millimetre), like the coordinate springs of
// LigamentSettings but acting along the ligament's own line.
struct LigamentBundle {
  std::string name;
  Eigen::Vector3d parent_insertion_m = Eigen::Vector3d::Zero();  // parent bone's mesh frame
  Eigen::Vector3d child_insertion_m = Eigen::Vector3d::Zero();   // child bone's mesh frame
  double slack_length_m = 0.0;                                   // > 0
  double stiffness_per_mm = 10.0;                                // residual per mm of stretch

  void validate() const;  // throws InputError naming the bundle and the field

  // Distance between the insertions for the bones' mesh-frame poses (any common frame).
  double length(const geometry::Pose& parent, const geometry::Pose& child) const;
  // How far the bundle is stretched beyond its slack length, in mm; 0 when slack.
  double stretchMm(const geometry::Pose& parent, const geometry::Pose& child) const;

  // The spring residual from the insertions' positions (any scalar type, e.g. ceres::Jet).
  template <typename T>
  T residual(const Eigen::Matrix<T, 3, 1>& parent_point,
             const Eigen::Matrix<T, 3, 1>& child_point) const {
    const T stretch_mm = ((parent_point - child_point).norm() - T(slack_length_m)) * 1000.0;
    return stretch_mm > T(0.0) ? T(stiffness_per_mm) * stretch_mm : T(0.0);
  }
};

// The largest stretch of any bundle, in mm (0 when every one is slack or there are none).
double maxStretchMm(const std::vector<LigamentBundle>& bundles, const geometry::Pose& parent,
                    const geometry::Pose& child);

}  // namespace constraints
}  // namespace fluoro_tracker
