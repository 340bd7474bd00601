#include "fluoro_tracker/registration/parent_relative_cost.h"

#include <gtest/gtest.h>

#include <vector>

#include <ceres/sized_cost_function.h>

#include "fluoro_tracker/registration/pose_increment.h"

using namespace fluoro_tracker;
using geometry::Pose;

namespace {

const Eigen::Vector3d kParentCentre(0.01, 0.02, 0.9);
const Eigen::Vector3d kChildCentre(0.015, -0.03, 0.91);
const double kParent[6] = {0.02, -0.05, 0.03, 0.004, -0.002, 0.01};
const double kRelative[6] = {-0.04, 0.01, 0.06, -0.003, 0.005, 0.002};

// Where a point of the child goes under an absolute increment about the child's centre.
Eigen::Vector3d moved(const double* increment, const Eigen::Vector3d& centre,
                      const Eigen::Vector3d& point) {
  return registration::applyIncrement(Pose::Identity(), centre, increment) * point;
}

// A test cost over one bone's increment: the moved positions of two of its points (6 residuals).
class MovedPoints : public ceres::SizedCostFunction<6, 6> {
 public:
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Vector3d a = moved(parameters[0], kChildCentre, {0.03, 0.0, 0.9});
    const Eigen::Vector3d b = moved(parameters[0], kChildCentre, {0.0, -0.05, 0.92});
    for (int k = 0; k < 3; ++k) {
      residuals[k] = a[k];
      residuals[3 + k] = b[k];
    }
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      // Central differences: this is the reference the chained Jacobians are checked against.
      for (int j = 0; j < 6; ++j) {
        double plus[6];
        double minus[6];
        std::copy(parameters[0], parameters[0] + 6, plus);
        std::copy(parameters[0], parameters[0] + 6, minus);
        plus[j] += 1e-7;
        minus[j] -= 1e-7;
        double rp[6];
        double rm[6];
        const double* pp[] = {plus};
        const double* pm[] = {minus};
        Evaluate(pp, rp, nullptr);
        Evaluate(pm, rm, nullptr);
        for (int i = 0; i < 6; ++i) jacobians[0][6 * i + j] = (rp[i] - rm[i]) / 2e-7;
      }
    }
    return true;
  }
};

// A test cost over both bones' increments, as a joint term has them: the gap between a point of
// the parent and one of the child, after their moves (3 residuals), with difference Jacobians.
class Gap : public ceres::SizedCostFunction<3, 6, 6> {
 public:
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Vector3d gap = moved(parameters[1], kChildCentre, {0.02, -0.01, 0.9}) -
                                moved(parameters[0], kParentCentre, {0.0, 0.03, 0.91});
    for (int k = 0; k < 3; ++k) residuals[k] = gap[k];
    for (int block = 0; jacobians != nullptr && block < 2; ++block) {
      if (jacobians[block] == nullptr) continue;
      for (int j = 0; j < 6; ++j) {
        double values[2][6];
        std::copy(parameters[0], parameters[0] + 6, values[0]);
        std::copy(parameters[1], parameters[1] + 6, values[1]);
        double rp[3];
        double rm[3];
        const double* pointers[] = {values[0], values[1]};
        values[block][j] += 1e-7;
        Evaluate(pointers, rp, nullptr);
        values[block][j] -= 2e-7;
        Evaluate(pointers, rm, nullptr);
        for (int i = 0; i < 3; ++i) jacobians[block][6 * i + j] = (rp[i] - rm[i]) / 2e-7;
      }
    }
    return true;
  }
};

}  // namespace

// The child's absolute increment is the parent's motion after the child's own.
TEST(ParentRelativeCost, ComposedIncrementMovesTheChildWithItsParent) {
  double absolute[6];
  registration::composeRelativeIncrement(kParent, kRelative, kParentCentre, kChildCentre, absolute);
  for (const Eigen::Vector3d& x :
       {Eigen::Vector3d(0.03, 0.0, 0.9), Eigen::Vector3d(-0.02, 0.04, 0.88)}) {
    const Eigen::Vector3d expected =
        moved(kParent, kParentCentre, moved(kRelative, kChildCentre, x));
    EXPECT_LT((moved(absolute, kChildCentre, x) - expected).norm(), 1e-12);
  }
  // No relative step: the child moves rigidly with the parent. No parent step: its own.
  const double zero[6] = {0, 0, 0, 0, 0, 0};
  registration::composeRelativeIncrement(zero, kRelative, kParentCentre, kChildCentre, absolute);
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(absolute[k], kRelative[k], 1e-12);
}

// A cost of two 6-parameter blocks (`first`, `second`, changed and restored here) whose
// Jacobians must match central differences of its residuals.
void expectJacobiansMatchDifferences(const ceres::CostFunction& cost, double* first,
                                     double* second) {
  ASSERT_EQ(cost.parameter_block_sizes().size(), 2u);
  const int rows = cost.num_residuals();
  const double* parameters[] = {first, second};
  std::vector<double> residuals(rows);
  std::vector<double> analytic_first(6 * rows);
  std::vector<double> analytic_second(6 * rows);
  double* jacobians[] = {analytic_first.data(), analytic_second.data()};
  ASSERT_TRUE(cost.Evaluate(parameters, residuals.data(), jacobians));
  std::vector<double> plus(rows);
  std::vector<double> minus(rows);
  for (int block = 0; block < 2; ++block) {
    double* values = block == 0 ? first : second;
    const std::vector<double>& analytic = block == 0 ? analytic_first : analytic_second;
    for (int j = 0; j < 6; ++j) {
      const double saved = values[j];
      values[j] = saved + 1e-6;
      cost.Evaluate(parameters, plus.data(), nullptr);
      values[j] = saved - 1e-6;
      cost.Evaluate(parameters, minus.data(), nullptr);
      values[j] = saved;
      for (int i = 0; i < rows; ++i) {
        EXPECT_NEAR(analytic[6 * i + j], (plus[i] - minus[i]) / 2e-6, 1e-6)
            << "block " << block << " residual " << i << " parameter " << j;
      }
    }
  }
}

// The wrapped cost's Jacobians, with respect to the relative increment and to the parent's
// (appended as a block), match central differences of the wrapped residuals.
TEST(ParentRelativeCost, JacobiansFollowTheChainRule) {
  const registration::ParentRelativeCost cost(new MovedPoints, 0, -1, kParentCentre, kChildCentre);
  double relative[6];
  double parent[6];
  std::copy(kRelative, kRelative + 6, relative);
  std::copy(kParent, kParent + 6, parent);
  expectJacobiansMatchDifferences(cost, relative, parent);
}

// A joint term already over the parent's increment: the chained term adds to its own.
TEST(ParentRelativeCost, JacobiansAddToAParentBlockTheTermHasAlready) {
  const registration::ParentRelativeCost cost(new Gap, 1, 0, kParentCentre, kChildCentre);
  double parent[6];
  double relative[6];
  std::copy(kParent, kParent + 6, parent);
  std::copy(kRelative, kRelative + 6, relative);
  expectJacobiansMatchDifferences(cost, parent, relative);
}
