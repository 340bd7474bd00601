#include "fluoro_tracker/registration/parent_relative_cost.h"

#include <ceres/jet.h>
#include <ceres/rotation.h>

namespace fluoro_tracker {
namespace registration {
namespace {

template <typename T>
void compose(const T* parent, const T* relative, const Eigen::Vector3d& parent_centre,
             const Eigen::Vector3d& child_centre, T* absolute) {
  T parent_r[9];  // column-major
  T relative_r[9];
  ceres::AngleAxisToRotationMatrix(parent, ceres::ColumnMajorAdapter3x3(parent_r));
  ceres::AngleAxisToRotationMatrix(relative, ceres::ColumnMajorAdapter3x3(relative_r));
  const Eigen::Map<const Eigen::Matrix<T, 3, 3>> rp(parent_r);
  const Eigen::Map<const Eigen::Matrix<T, 3, 3>> rr(relative_r);
  T combined[9];
  Eigen::Map<Eigen::Matrix<T, 3, 3>> combined_map(combined);
  combined_map = rp * rr;
  ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(static_cast<const T*>(combined)),
                                   absolute);
  const Eigen::Matrix<T, 3, 1> cp = parent_centre.cast<T>();
  const Eigen::Matrix<T, 3, 1> cc = child_centre.cast<T>();
  const Eigen::Matrix<T, 3, 1> tp(parent[3], parent[4], parent[5]);
  const Eigen::Matrix<T, 3, 1> tr(relative[3], relative[4], relative[5]);
  const Eigen::Matrix<T, 3, 1> t = rp * (cc + tr - cp) + cp + tp - cc;
  for (int k = 0; k < 3; ++k) absolute[3 + k] = t[k];
}

}  // namespace

void composeRelativeIncrement(const double* parent, const double* relative,
                              const Eigen::Vector3d& parent_centre,
                              const Eigen::Vector3d& child_centre, double* absolute,
                              double* d_parent, double* d_relative) {
  if (d_parent == nullptr && d_relative == nullptr) {
    compose(parent, relative, parent_centre, child_centre, absolute);
    return;
  }
  using Jet = ceres::Jet<double, 12>;
  Jet p[6];
  Jet r[6];
  for (int k = 0; k < 6; ++k) {
    p[k] = Jet(parent[k], k);
    r[k] = Jet(relative[k], 6 + k);
  }
  Jet a[6];
  compose(p, r, parent_centre, child_centre, a);
  for (int i = 0; i < 6; ++i) {
    absolute[i] = a[i].a;
    for (int j = 0; j < 6; ++j) {
      if (d_parent != nullptr) d_parent[6 * i + j] = a[i].v[j];
      if (d_relative != nullptr) d_relative[6 * i + j] = a[i].v[6 + j];
    }
  }
}

ParentRelativeCost::ParentRelativeCost(ceres::CostFunction* inner, int child_block,
                                       int parent_block, const Eigen::Vector3d& parent_centre,
                                       const Eigen::Vector3d& child_centre)
    : inner_(inner),
      child_block_(child_block),
      parent_block_(parent_block),
      parent_in_inner_(parent_block >= 0),
      parent_centre_(parent_centre),
      child_centre_(child_centre) {
  set_num_residuals(inner_->num_residuals());
  *mutable_parameter_block_sizes() = inner_->parameter_block_sizes();
  if (!parent_in_inner_) {
    parent_block_ = static_cast<int>(parameter_block_sizes().size());
    mutable_parameter_block_sizes()->push_back(6);
  }
  inner_parameters_.resize(inner_->parameter_block_sizes().size());
  inner_jacobians_.resize(inner_->parameter_block_sizes().size());
  child_jacobian_.resize(static_cast<std::size_t>(num_residuals()) * 6);
}

bool ParentRelativeCost::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  double absolute[6];
  double d_parent[36];
  double d_relative[36];
  const bool want_child = jacobians != nullptr && (jacobians[child_block_] != nullptr ||
                                                   jacobians[parent_block_] != nullptr);
  composeRelativeIncrement(parameters[parent_block_], parameters[child_block_], parent_centre_,
                           child_centre_, absolute, want_child ? d_parent : nullptr,
                           want_child ? d_relative : nullptr);
  for (std::size_t k = 0; k < inner_parameters_.size(); ++k) {
    inner_parameters_[k] = static_cast<int>(k) == child_block_ ? absolute : parameters[k];
    if (jacobians != nullptr) {
      inner_jacobians_[k] = static_cast<int>(k) == child_block_
                                ? (want_child ? child_jacobian_.data() : nullptr)
                                : jacobians[k];
    }
  }
  if (!inner_->Evaluate(inner_parameters_.data(), residuals,
                        jacobians != nullptr ? inner_jacobians_.data() : nullptr)) {
    return false;
  }
  if (!want_child) return true;
  const int rows = num_residuals();
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>;
  const Eigen::Map<const RowMajor> child(child_jacobian_.data(), rows, 6);
  using Square = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;
  if (jacobians[child_block_] != nullptr) {
    Eigen::Map<RowMajor>(jacobians[child_block_], rows, 6).noalias() =
        child * Eigen::Map<const Square>(d_relative);
  }
  if (jacobians[parent_block_] != nullptr) {
    Eigen::Map<RowMajor> parent(jacobians[parent_block_], rows, 6);
    if (parent_in_inner_) {
      parent.noalias() += child * Eigen::Map<const Square>(d_parent);
    } else {
      parent.noalias() = child * Eigen::Map<const Square>(d_parent);
    }
  }
  return true;
}

}  // namespace registration
}  // namespace fluoro_tracker
