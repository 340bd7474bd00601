#include "fluoro_tracker/registration/compressed_residuals_cost.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Core>

using fluoro_tracker::registration::CompressedResidualsCost;

namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Many residuals over two small blocks, nonlinear in both: r_i = a0 sin(a1 t_i) + a2 t_i^2 +
// b0 cos(t_i) - y_i, for blocks a (3) and b (1); `b_used` false leaves b out (a column of zeros,
// a singular J^T J).
class Curve : public ceres::CostFunction {
 public:
  explicit Curve(bool b_used) : b_used_(b_used) {
    set_num_residuals(kSamples);
    mutable_parameter_block_sizes()->push_back(3);
    mutable_parameter_block_sizes()->push_back(1);
  }
  bool Evaluate(double const* const* p, double* r, double** j) const override {
    const double* a = p[0];
    const double b = b_used_ ? p[1][0] : 0.0;
    for (int i = 0; i < kSamples; ++i) {
      const double t = 0.01 * i;
      const double y =
          1.3 * std::sin(0.7 * t) - 0.2 * t * t + 0.4 * std::cos(t) + 0.01 * std::sin(37.0 * t);
      r[i] = a[0] * std::sin(a[1] * t) + a[2] * t * t + b * std::cos(t) - y;
      if (j == nullptr) continue;
      if (j[0] != nullptr) {
        j[0][3 * i] = std::sin(a[1] * t);
        j[0][3 * i + 1] = a[0] * t * std::cos(a[1] * t);
        j[0][3 * i + 2] = t * t;
      }
      if (j[1] != nullptr) j[1][i] = b_used_ ? std::cos(t) : 0.0;
    }
    return true;
  }
  static constexpr int kSamples = 400;

 private:
  bool b_used_;
};

// Residuals and Jacobians of `cost` at (a, b), stacked (blocks side by side).
void evaluate(const ceres::CostFunction& cost, const double* a, const double* b,
              Eigen::VectorXd* residuals, Eigen::MatrixXd* jacobian) {
  const int n = cost.num_residuals();
  residuals->resize(n);
  std::vector<double> ja(static_cast<std::size_t>(n) * 3);
  std::vector<double> jb(static_cast<std::size_t>(n));
  const double* parameters[] = {a, b};
  double* jacobians[] = {ja.data(), jb.data()};
  ASSERT_TRUE(cost.Evaluate(parameters, residuals->data(), jacobians));
  jacobian->resize(n, 4);
  jacobian->leftCols(3) = Eigen::Map<RowMajor>(ja.data(), n, 3);
  jacobian->col(3) = Eigen::Map<Eigen::VectorXd>(jb.data(), n);
  // Without Jacobians (Ceres' candidate steps): the same cost.
  Eigen::VectorXd alone(n);
  ASSERT_TRUE(cost.Evaluate(parameters, alone.data(), nullptr));
  EXPECT_NEAR(alone.norm(), residuals->norm(), 1e-12 * (1.0 + residuals->norm()));
}

}  // namespace

// Cost, gradient and Gauss-Newton matrix equal the original's, whether J^T J is regular
// (Cholesky) or singular (a block no residual depends on: the eigen decomposition).
TEST(CompressedResidualsCost, KeepsCostGradientAndNormalMatrix) {
  for (bool b_used : {true, false}) {
    const Curve curve(b_used);
    const CompressedResidualsCost compressed(new Curve(b_used));
    EXPECT_EQ(compressed.num_residuals(), 5);
    EXPECT_EQ(compressed.represented(), Curve::kSamples);
    const double a[3] = {1.1, 0.8, -0.1};
    const double b[1] = {0.3};
    Eigen::VectorXd r;
    Eigen::MatrixXd j;
    Eigen::VectorXd c;
    Eigen::MatrixXd jc;
    evaluate(curve, a, b, &r, &j);
    evaluate(compressed, a, b, &c, &jc);
    EXPECT_NEAR(c.squaredNorm(), r.squaredNorm(), 1e-10 * r.squaredNorm()) << b_used;
    const Eigen::VectorXd gradient = j.transpose() * r;
    const Eigen::MatrixXd normal = j.transpose() * j;
    EXPECT_LT((jc.transpose() * c - gradient).norm(), 1e-9 * gradient.norm()) << b_used;
    EXPECT_LT((jc.transpose() * jc - normal).norm(), 1e-9 * normal.norm()) << b_used;
  }
}

// Levenberg-Marquardt through Ceres reaches the same solution and cost, in as many iterations.
TEST(CompressedResidualsCost, SolvesAsTheOriginal) {
  double solutions[2][4] = {{0.6, 0.9, 0.2, 0.0}, {0.6, 0.9, 0.2, 0.0}};
  ceres::Solver::Summary summaries[2];
  for (int k = 0; k < 2; ++k) {
    ceres::Problem problem;
    ceres::CostFunction* cost = new Curve(true);
    if (k == 1) cost = new CompressedResidualsCost(cost);
    problem.AddResidualBlock(cost, nullptr, solutions[k], solutions[k] + 3);
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::DENSE_QR;
    options.function_tolerance = 1e-14;
    options.gradient_tolerance = 1e-14;
    options.parameter_tolerance = 1e-14;
    ceres::Solve(options, &problem, &summaries[k]);
    ASSERT_TRUE(summaries[k].IsSolutionUsable());
  }
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(solutions[1][i], solutions[0][i], 1e-7) << i;
  EXPECT_NEAR(summaries[1].final_cost, summaries[0].final_cost, 1e-9);
  EXPECT_EQ(summaries[1].iterations.size(), summaries[0].iterations.size());
  // The data's own coefficients, up to the small unmodelled ripple.
  EXPECT_NEAR(solutions[1][0], 1.3, 0.02);
  EXPECT_NEAR(solutions[1][3], 0.4, 0.02);
}
