#pragma once

#include <memory>
#include <vector>

#include <ceres/cost_function.h>
#include <Eigen/Core>

namespace fluoro_tracker {
namespace registration {

// The parent-relative parameterisation of a joint's child (the dissertation's Dataset B): the
// child's unknown is its increment relative to its parent, so a step of the parent carries the
// child along, and the child's own increment moves it from there. As increments about each
// bone's centre (pose_increment.h), the child's absolute increment is the parent's motion after
// the child's own: rotation R(w_p) R(w_r), translation R(w_p)(c_c + t_r - c_p) + c_p + t_p - c_c.
// Computes it and, when asked, its 6 x 6 Jacobians (row-major) with respect to the parent's and
// the relative increment.
void composeRelativeIncrement(const double* parent, const double* relative,
                              const Eigen::Vector3d& parent_centre,
                              const Eigen::Vector3d& child_centre, double* absolute,
                              double* d_parent = nullptr, double* d_relative = nullptr);

// Wraps a cost whose parameter block `child_block` is a child bone's absolute increment so that
// the block becomes the child's relative increment and the parent's increment joins: at
// `parent_block` when the wrapped cost already has it (contact, ligaments), else appended as
// the last block (image terms). The Jacobians follow by the chain rule. Takes ownership of
// `inner`. Not thread-safe (scratch buffers: an evaluation allocates nothing).
class ParentRelativeCost : public ceres::CostFunction {
 public:
  ParentRelativeCost(ceres::CostFunction* inner, int child_block, int parent_block,
                     const Eigen::Vector3d& parent_centre, const Eigen::Vector3d& child_centre);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  int child_block_;
  int parent_block_;  // in the outer cost's blocks
  bool parent_in_inner_;
  Eigen::Vector3d parent_centre_;
  Eigen::Vector3d child_centre_;
  mutable std::vector<const double*> inner_parameters_;
  mutable std::vector<double*> inner_jacobians_;
  mutable std::vector<double> child_jacobian_;  // residuals x 6, row-major
};

}  // namespace registration
}  // namespace fluoro_tracker
