#include "fluoro_tracker/registration/contact_cost.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "fluoro_tracker/registration/pose_increment.h"

namespace fluoro_tracker {
namespace registration {

ContactCost::ContactCost(const constraints::ArticularContact* contact,
                         const geometry::Pose& parent_pose, const Eigen::Vector3d& parent_centre,
                         const geometry::Pose& child_pose, const Eigen::Vector3d& child_centre,
                         double reach_m)
    : contact_(contact), parent_centre_(parent_centre), child_centre_(child_centre) {
  const geometry::Pose child_from_fixed = child_pose.inverse();
  child_rotation_t_ = child_from_fixed.linear();
  child_translation_inv_ = child_from_fixed.translation();
  const geometry::Pose child_from_parent = child_from_fixed * parent_pose;
  const auto& samples = contact_->samples();
  // A separation measure looks for the nearest sample wherever it is: no culling.
  const bool keep_all = contact_->settings().measure == constraints::ContactMeasure::kSeparation;
  const double reach = reach_m + contact_->settings().dead_band_mm * 1e-3;
  // Samples outside the grid's box lie beyond its margin, farther than the reach: left out
  // without a look-up (the same samples as with one). Many of a femoral component's are (its
  // flange, the condyles not over the insert): building the term took 275 -> 184 us (crude
  // starts, simulated knee), and it is built every outer iteration.
  const geometry::SignedDistanceGrid& grid = contact_->grid();
  const bool skip_outside = !keep_all && grid.outsideLowerBound() > reach;
  std::vector<int> kept;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Eigen::Vector3d in_child = child_from_parent * samples[i];
    if (skip_outside && !grid.contains(in_child)) continue;
    if (keep_all || grid.distance(in_child) <= reach) {
      kept.push_back(static_cast<int>(i));
      parent_points_.push_back(parent_pose * samples[i]);
    }
  }
  // Samples left out read as far outside, so they add nothing to any measure, which then
  // needs only the kept samples and their triangles.
  part_ = contact_->subset(std::move(kept));
  distances_.assign(samples.size(), 1.0);
  d_measure_.assign(samples.size(), 0.0);
  gradients_.resize(part_.samples.size());
  rotated_parent_.resize(part_.samples.size());
  rotated_child_.resize(part_.samples.size());
}

bool ContactCost::Evaluate(double const* const* parameters, double* residuals,
                           double** jacobians) const {
  const double* parent_increment = parameters[0];
  const double* child_increment = parameters[1];
  const Eigen::Vector3d parent_w(parent_increment[0], parent_increment[1], parent_increment[2]);
  const Eigen::Vector3d parent_t(parent_increment[3], parent_increment[4], parent_increment[5]);
  const Eigen::Vector3d child_w(child_increment[0], child_increment[1], child_increment[2]);
  const Eigen::Vector3d child_t(child_increment[3], child_increment[4], child_increment[5]);
  const Eigen::Matrix3d parent_r = rotationFromAxisAngle(parent_w);
  const Eigen::Matrix3d child_r_t = rotationFromAxisAngle(child_w).transpose();
  const bool want_jacobians = jacobians != nullptr && (jacobians[0] || jacobians[1]);

  // A parent sample p moves to p' = Rp (p - cp) + cp + tp; the child's frame moves the same
  // way, so p' lies at y = C^-1 (Rc^T (p' - cc - tc) + cc) in the child's mesh frame.
  for (std::size_t k = 0; k < part_.samples.size(); ++k) {
    const Eigen::Vector3d rotated = parent_r * (parent_points_[k] - parent_centre_);
    const Eigen::Vector3d moved = rotated + parent_centre_ + parent_t;
    const Eigen::Vector3d in_child = child_r_t * (moved - child_centre_ - child_t);
    const Eigen::Vector3d y =
        child_rotation_t_ * (in_child + child_centre_) + child_translation_inv_;
    distances_[part_.samples[k]] =
        contact_->grid().distance(y, want_jacobians ? &gradients_[k] : nullptr);
    rotated_parent_[k] = rotated;
    rotated_child_[k] = in_child;
  }
  const double m =
      contact_->measure(distances_.data(), want_jacobians ? d_measure_.data() : nullptr, part_);
  double d_penalty = 0.0;
  residuals[0] = contact_->penalty(m, &d_penalty);
  if (!want_jacobians) return true;

  Eigen::Matrix<double, 1, 6> d_parent = Eigen::Matrix<double, 1, 6>::Zero();
  Eigen::Matrix<double, 1, 6> d_child = Eigen::Matrix<double, 1, 6>::Zero();
  for (std::size_t k = 0; k < part_.samples.size(); ++k) {
    const double coefficient = d_penalty * d_measure_[part_.samples[k]];
    if (coefficient == 0.0) continue;
    // d(distance)/d(child-frame point) -> d/d(moved point in the fixed frame).
    const Eigen::RowVector3d g_child = gradients_[k].transpose() * child_rotation_t_;
    const Eigen::RowVector3d g_fixed = g_child * child_r_t;
    d_parent.head<3>() += coefficient * (-g_fixed * skew(rotated_parent_[k]));
    d_parent.tail<3>() += coefficient * g_fixed;
    d_child.head<3>() += coefficient * (g_child * skew(rotated_child_[k]));
    d_child.tail<3>() -= coefficient * g_fixed;
  }
  // The rotation parts need the SO(3) Jacobians of the increments: d/dw R(w)v = -[R(w)v]x J(w)
  // and d/dw R(w)^T u = [R(w)^T u]x J(-w).
  const Eigen::RowVector3d parent_rot = d_parent.head<3>() * so3LeftJacobian(parent_w);
  const Eigen::RowVector3d child_rot = d_child.head<3>() * so3LeftJacobian(-child_w);
  d_parent.head<3>() = parent_rot;
  d_child.head<3>() = child_rot;
  if (jacobians[0]) std::copy(d_parent.data(), d_parent.data() + 6, jacobians[0]);
  if (jacobians[1]) std::copy(d_child.data(), d_child.data() + 6, jacobians[1]);
  return true;
}

}  // namespace registration
}  // namespace fluoro_tracker
