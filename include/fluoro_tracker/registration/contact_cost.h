#pragma once

#include <vector>

#include <ceres/sized_cost_function.h>

#include "fluoro_tracker/constraints/articular_contact.h"
#include "fluoro_tracker/geometry/pose.h"

namespace fluoro_tracker {
namespace registration {

// Articular contact as one Ceres residual: weight x measure^exponent of the parent's sampled
// surface against the child's signed distance grid (constraints::ArticularContact). Two
// parameter blocks: the parent's and the child's pose increments (pose_increment.h), so the
// solver moves both bones to relieve penetration. Analytic Jacobians through the grid's
// gradient.
//
// Samples farther than `reach_m` from the child's surface at the linearisation poses are left
// out (the registrar rebuilds the cost every outer iteration, and one outer iteration moves a
// bone far less than that). Not thread-safe: it keeps scratch buffers so that an evaluation
// allocates nothing.
class ContactCost : public ceres::SizedCostFunction<1, 6, 6> {
 public:
  // `contact` must outlive the cost. Poses and rotation centres in the fixed frame.
  ContactCost(const constraints::ArticularContact* contact, const geometry::Pose& parent_pose,
              const Eigen::Vector3d& parent_centre, const geometry::Pose& child_pose,
              const Eigen::Vector3d& child_centre, double reach_m = 0.005);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  // Number of samples evaluated (after culling).
  std::size_t activeSamples() const { return part_.samples.size(); }

 private:
  const constraints::ArticularContact* contact_;
  constraints::ArticularContact::SampleSubset part_;  // samples kept, and their triangles
  std::vector<Eigen::Vector3d> parent_points_;  // active samples at the parent's pose, fixed frame
  Eigen::Vector3d parent_centre_;
  Eigen::Vector3d child_centre_;
  Eigen::Matrix3d child_rotation_t_;  // child_pose^-1: rotation and translation
  Eigen::Vector3d child_translation_inv_;
  mutable std::vector<double> distances_;
  mutable std::vector<double> d_measure_;
  mutable std::vector<Eigen::Vector3d> gradients_;  // per active sample, child frame
  mutable std::vector<Eigen::Vector3d> rotated_parent_;
  mutable std::vector<Eigen::Vector3d> rotated_child_;
};

}  // namespace registration
}  // namespace fluoro_tracker
