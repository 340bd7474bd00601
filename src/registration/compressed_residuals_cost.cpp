#include "fluoro_tracker/registration/compressed_residuals_cost.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace fluoro_tracker {
namespace registration {

CompressedResidualsCost::CompressedResidualsCost(ceres::CostFunction* inner) : inner_(inner) {
  for (const int size : inner_->parameter_block_sizes()) {
    mutable_parameter_block_sizes()->push_back(size);
    parameters_ += size;
  }
  set_num_residuals(parameters_ + 1);
  stacked_.resize(inner_->num_residuals(), parameters_);
  inner_residuals_.resize(static_cast<std::size_t>(inner_->num_residuals()));
  for (const int size : inner_->parameter_block_sizes()) {
    inner_jacobians_.emplace_back(static_cast<std::size_t>(inner_->num_residuals() * size));
  }
  for (auto& buffer : inner_jacobians_) inner_jacobian_pointers_.push_back(buffer.data());
}

bool CompressedResidualsCost::Evaluate(double const* const* parameters, double* residuals,
                                       double** jacobians) const {
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const int n = inner_->num_residuals();
  const int p = parameters_;
  const Eigen::Map<const Eigen::VectorXd> r(inner_residuals_.data(), n);
  if (jacobians == nullptr) {
    if (!inner_->Evaluate(parameters, inner_residuals_.data(), nullptr)) return false;
    std::fill(residuals, residuals + p, 0.0);
    residuals[p] = r.norm();
    return true;
  }
  // Every block's Jacobian, also of blocks Ceres holds constant: R^T R = J^T J holds block by
  // block, so the free blocks' part is exact whichever are free.
  if (!inner_->Evaluate(parameters, inner_residuals_.data(), inner_jacobian_pointers_.data())) {
    return false;
  }

  const std::vector<int32_t>& sizes = inner_->parameter_block_sizes();
  // J column-major, so that each entry of J^T J and J^T r is a dot product of two contiguous
  // columns thousands long (vectorised), not a sum of thousands of small rank-one updates.
  for (std::size_t k = 0, ok = 0; k < sizes.size(); ok += sizes[k], ++k) {
    stacked_.middleCols(ok, sizes[k]) =
        Eigen::Map<const RowMajor>(inner_jacobians_[k].data(), n, sizes[k]);
  }
  Eigen::MatrixXd normal(p, p);
  Eigen::VectorXd gradient(p);
  for (int a = 0; a < p; ++a) {
    gradient(a) = stacked_.col(a).dot(r);
    for (int b = a; b < p; ++b) normal(a, b) = normal(b, a) = stacked_.col(a).dot(stacked_.col(b));
  }
  const double squared_norm = r.squaredNorm();

  // R (upper, p x p) with R^T R = J^T J, and q with R^T q = J^T r.
  Eigen::MatrixXd factor(p, p);
  Eigen::VectorXd q(p);
  const Eigen::LLT<Eigen::MatrixXd> cholesky(normal);
  bool factored = cholesky.info() == Eigen::Success;
  if (factored) {
    factor = cholesky.matrixU();
    q = cholesky.matrixL().solve(gradient);
    // A nearly singular J^T J can factor yet lose q to rounding; q^T q <= r^T r must hold.
    factored = q.allFinite() && q.squaredNorm() <= squared_norm * (1.0 + 1e-9) + 1e-300;
  }
  if (!factored) {
    // Singular (a parameter no residual depends on): R = D^1/2 V^T over the directions the data
    // constrain; the gradient has no component along the others.
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(normal);
    if (eigen.info() != Eigen::Success) return false;
    const double largest = std::max(eigen.eigenvalues().maxCoeff(), 0.0);
    const Eigen::VectorXd projected = eigen.eigenvectors().transpose() * gradient;
    for (int i = 0; i < p; ++i) {
      const double value = eigen.eigenvalues()(i);
      const bool kept = value > 1e-12 * largest && value > 0.0;
      const double root = kept ? std::sqrt(value) : 0.0;
      factor.row(i) = root * eigen.eigenvectors().col(i).transpose();
      q(i) = kept ? projected(i) / root : 0.0;
    }
  }
  for (int i = 0; i < p; ++i) residuals[i] = q(i);
  residuals[p] = std::sqrt(std::max(0.0, squared_norm - q.squaredNorm()));

  for (std::size_t k = 0, ok = 0; k < sizes.size(); ok += sizes[k], ++k) {
    if (jacobians[k] == nullptr) continue;
    Eigen::Map<RowMajor> out(jacobians[k], p + 1, sizes[k]);
    out.topRows(p) = factor.middleCols(ok, sizes[k]);
    out.row(p).setZero();
  }
  return true;
}

}  // namespace registration
}  // namespace fluoro_tracker
