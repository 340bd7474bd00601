#pragma once

#include <memory>
#include <vector>

#include <ceres/cost_function.h>
#include <Eigen/Core>

namespace fluoro_tracker {
namespace registration {

// Presents a cost with many residuals over few parameters (a bone's contour term: thousands of
// samples, 7 parameters) to Ceres as P + 1 residuals, P the parameters' total size, that give
// Ceres exactly what it uses of the original: the same cost (half the squared norm), and at
// every linearisation the same gradient J^T r and Gauss-Newton matrix J^T J. With J^T J =
// R^T R (Cholesky, or an eigen decomposition where it is singular) the residuals are q =
// R^-T J^T r and sqrt(r^T r - q^T q), with Jacobian [R; 0]: ||q + R d||^2 + (r^T r - q^T q) =
// ||r + J d||^2 for every step d. Levenberg-Marquardt steps, their model and actual cost changes
// and the covariance (J^T J)^-1 are therefore those of the original; but Ceres' own work per
// iteration (the Jacobian's storage, validity checks, column scaling, forming J^T J) shrinks
// from thousands of rows to P + 1. Only the residual count differs: a caller estimating the
// residual variance adds represented() - num_residuals() back.
// Takes ownership of `inner`. Not thread-safe (scratch buffers).
class CompressedResidualsCost : public ceres::CostFunction {
 public:
  explicit CompressedResidualsCost(ceres::CostFunction* inner);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  int represented() const { return inner_->num_residuals(); }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  int parameters_ = 0;  // P
  mutable std::vector<double> inner_residuals_;
  mutable std::vector<std::vector<double>> inner_jacobians_;  // per block, row-major
  mutable std::vector<double*> inner_jacobian_pointers_;      // to each block's buffer
  mutable Eigen::MatrixXd stacked_;                           // all blocks, column-major
};

}  // namespace registration
}  // namespace fluoro_tracker
