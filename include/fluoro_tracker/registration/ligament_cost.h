#pragma once

#include <ceres/cost_function.h>

#include "fluoro_tracker/constraints/ligament_envelope.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/kinematics/knee_coordinates.h"

namespace fluoro_tracker {
namespace registration {

// Ligament-like springs of a joint of the knee's kind as a Ceres cost: six residuals
// (constraints::ligamentResiduals) of the knee coordinates of the parent's and child's frames,
// moved by their pose increments (pose_increment.h). Automatic derivatives (a handful of
// residuals; the coordinate formulas are not worth differentiating by hand). `parent_frame`
// and `child_frame`: the joint's knee frames (JointModel::parentKneeFrame: the anatomical
// frames, turned for a patellofemoral joint) in the fixed frame at the linearisation.
ceres::CostFunction* makeKneeLigamentCost(const constraints::LigamentSettings& settings,
                                          kinematics::Side side, const geometry::Pose& parent_frame,
                                          const Eigen::Vector3d& parent_centre,
                                          const geometry::Pose& child_frame,
                                          const Eigen::Vector3d& child_centre);

// A glenohumeral joint's springs (constraints::glenohumeralSpringResiduals, on the ISB's Y-X-Y
// angles and the translations) as a Ceres cost, likewise: six residuals, automatic derivatives.
ceres::CostFunction* makeGlenohumeralLigamentCost(const constraints::LigamentSettings& settings,
                                                  kinematics::Side side,
                                                  const geometry::Pose& parent_frame,
                                                  const Eigen::Vector3d& parent_centre,
                                                  const geometry::Pose& child_frame,
                                                  const Eigen::Vector3d& child_centre);

// Ligament bundles (constraints::LigamentBundle) as a Ceres cost: one residual per bundle, from
// its insertions on the two bones moved by their pose increments; automatic derivatives.
// `parent_pose` and `child_pose`: the bones' mesh-frame poses in the fixed frame at the
// linearisation. Returns nullptr for no bundles.
ceres::CostFunction* makeLigamentBundleCost(const std::vector<constraints::LigamentBundle>& bundles,
                                            const geometry::Pose& parent_pose,
                                            const Eigen::Vector3d& parent_centre,
                                            const geometry::Pose& child_pose,
                                            const Eigen::Vector3d& child_centre);

}  // namespace registration
}  // namespace fluoro_tracker
