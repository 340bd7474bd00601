#include "fluoro_tracker/registration/edge_to_contour_cost.h"

#include <vector>

#include <gtest/gtest.h>

#include "fluoro_tracker/geometry/xray_camera.h"

using fluoro_tracker::geometry::Pose;
using fluoro_tracker::geometry::XrayCamera;
using fluoro_tracker::registration::EdgeToContourCost;

namespace {

// A 1024 x 1024 view looking down +z; pairs around a ring of contour points 1 m away, each
// paired with an edge pixel a few pixels off its projection along its normal (some beyond the
// Cauchy scale, where the kernel bends).
struct Ring {
  XrayCamera camera{1024, 1024, 3000.0, 3000.0, 512.0, 512.0, "view"};
  std::vector<EdgeToContourCost::Pair> pairs;
  Eigen::Vector3d centre{0.0, 0.0, 1.0};

  Ring() {
    camera.setWorldFromCamera(Pose::Identity());
    for (int k = 0; k < 24; ++k) {
      const double a = 2.0 * M_PI * k / 24.0;
      const Eigen::Vector2d normal(std::cos(a), std::sin(a));
      EdgeToContourCost::Pair pair;
      pair.contour_point_fixed = centre + 0.03 * Eigen::Vector3d(normal.x(), normal.y(), 0.2);
      pair.normal = normal;
      Eigen::Vector2d pixel;
      camera.project(pair.contour_point_fixed, &pixel);
      pair.edge_pixel = pixel + (0.5 + 0.4 * k) * normal;  // 0.5 to 9.7 px outward
      pair.offset_gain = 1.0;
      pairs.push_back(pair);
    }
  }
  EdgeToContourCost cost() const { return EdgeToContourCost(camera, pairs, centre, 4.0, 2.0); }
};

std::vector<double> residualsAt(const EdgeToContourCost& cost, const double* increment,
                                double offset, std::vector<double>* jac = nullptr,
                                std::vector<double>* jac_offset = nullptr) {
  const double* parameters[2] = {increment, &offset};
  std::vector<double> residuals(static_cast<std::size_t>(cost.num_residuals()));
  double* jacobians[2] = {jac ? jac->data() : nullptr, jac_offset ? jac_offset->data() : nullptr};
  EXPECT_TRUE(cost.Evaluate(parameters, residuals.data(), jac ? jacobians : nullptr));
  return residuals;
}

}  // namespace

// Its analytic Jacobians (pose increment and edge offset) match central differences.
TEST(EdgeToContourCost, JacobiansMatchFiniteDifferences) {
  const Ring ring;
  const EdgeToContourCost cost = ring.cost();
  const std::size_t n = ring.pairs.size();
  const double x[6] = {0.01, -0.02, 0.015, 0.0003, -0.0002, 0.0004};
  const double offset = 0.3;
  std::vector<double> jac(6 * n);
  std::vector<double> jac_offset(n);
  residualsAt(cost, x, offset, &jac, &jac_offset);
  for (int k = 0; k < 7; ++k) {
    const double h = k < 3 ? 1e-6 : (k < 6 ? 1e-8 : 1e-5);
    double xp[6];
    double xm[6];
    std::copy(x, x + 6, xp);
    std::copy(x, x + 6, xm);
    double op = offset;
    double om = offset;
    if (k < 6) {
      xp[k] += h;
      xm[k] -= h;
    } else {
      op += h;
      om -= h;
    }
    const std::vector<double> rp = residualsAt(cost, xp, op);
    const std::vector<double> rm = residualsAt(cost, xm, om);
    for (std::size_t i = 0; i < n; ++i) {
      const double numeric = (rp[i] - rm[i]) / (2.0 * h);
      const double analytic = k < 6 ? jac[6 * i + k] : jac_offset[i];
      EXPECT_NEAR(analytic, numeric, 1e-4 * std::max(1.0, std::abs(numeric)))
          << "parameter " << k << " pair " << i;
    }
  }
}

// It keeps its residuals between a cost-only evaluation and the Jacobian evaluation at the same
// parameters; wherever the parameters moved, it works them out afresh, so every evaluation
// equals a new cost's.
TEST(EdgeToContourCost, KeptResidualsAreThoseOfTheParametersAsked) {
  const Ring ring;
  const EdgeToContourCost cost = ring.cost();
  const std::size_t n = ring.pairs.size();
  const double a[6] = {0.01, -0.02, 0.015, 0.0003, -0.0002, 0.0004};
  const double b[6] = {-0.02, 0.01, 0.0, -0.0004, 0.0003, -0.001};
  std::vector<double> jac(6 * n);
  std::vector<double> jac_offset(n);
  std::vector<double> fresh_jac(6 * n);
  std::vector<double> fresh_jac_offset(n);
  const auto fresh = [&](const double* x, double offset) {
    const EdgeToContourCost other = ring.cost();
    return residualsAt(other, x, offset, &fresh_jac, &fresh_jac_offset);
  };
  // Cost at a, then Jacobians at a (kept), at b (moved), cost at b then a, Jacobians at a again,
  // and the offset alone moved.
  EXPECT_EQ(residualsAt(cost, a, 0.2), fresh(a, 0.2));
  EXPECT_EQ(residualsAt(cost, a, 0.2, &jac, &jac_offset), fresh(a, 0.2));
  EXPECT_EQ(jac, fresh_jac);
  EXPECT_EQ(jac_offset, fresh_jac_offset);
  EXPECT_EQ(residualsAt(cost, b, 0.2, &jac, &jac_offset), fresh(b, 0.2));
  EXPECT_EQ(jac, fresh_jac);
  EXPECT_EQ(residualsAt(cost, b, 0.2), fresh(b, 0.2));
  EXPECT_EQ(residualsAt(cost, a, 0.2), fresh(a, 0.2));
  EXPECT_EQ(residualsAt(cost, a, 0.2, &jac, &jac_offset), fresh(a, 0.2));
  EXPECT_EQ(jac, fresh_jac);
  EXPECT_EQ(residualsAt(cost, a, -0.4), fresh(a, -0.4));
  EXPECT_NE(fresh(a, -0.4), fresh(a, 0.2));
  EXPECT_NE(fresh(a, 0.2), fresh(b, 0.2));
}

// A pair's rounding (the edge expected that far inside its sample) counts as the edge lying that
// much farther out: the same residuals as the edge moved outward along the normal.
TEST(EdgeToContourCost, RoundingCountsAsTheEdgeFartherOut) {
  Ring rounded;
  Ring moved;
  for (std::size_t k = 0; k < rounded.pairs.size(); ++k) {
    const double rounding = 0.1 * static_cast<double>(k % 5) - 0.2;
    rounded.pairs[k].rounding = rounding;
    moved.pairs[k].edge_pixel += rounding * moved.pairs[k].normal;
  }
  const double x[6] = {0.01, -0.02, 0.015, 0.0003, -0.0002, 0.0004};
  const auto a = residualsAt(rounded.cost(), x, 0.3);
  const auto b = residualsAt(moved.cost(), x, 0.3);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_NEAR(a[k], b[k], 1e-9) << "pair " << k;
}
