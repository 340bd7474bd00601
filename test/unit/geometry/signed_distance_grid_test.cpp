#include "fluoro_tracker/geometry/signed_distance_grid.h"

#include <cmath>

#include <gtest/gtest.h>

#include "../test_support.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/sim/mesh_builder.h"

namespace fluoro_tracker {
namespace geometry {
namespace {

TEST(SignedDistanceGrid, MatchesASphereInsideAndOutsideWithItsGradient) {
  const double radius = 0.02;
  const Mesh sphere = sim::uvSphere(radius, 96, 192);
  const SignedDistanceGrid grid(sphere);
  // Inside the exact band, in the chamfer region deep inside, and outside: the polygonal
  // sphere lies within 0.02 mm of the true one; the chamfer pass is a few percent long.
  for (const Eigen::Vector3d& direction :
       {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0.3, -0.5, 0.8).normalized(),
        Eigen::Vector3d(-0.6, 0.7, 0.2).normalized()}) {
    for (double r : {0.0185, 0.0199, 0.0201, 0.022, 0.028}) {
      Eigen::Vector3d gradient;
      const double d = grid.distance(r * direction, &gradient);
      const bool in_band = std::abs(r - radius) <= 3e-3;
      EXPECT_NEAR(d, r - radius, in_band ? 3e-5 : 0.08 * std::abs(r - radius)) << "r " << r;
      EXPECT_GT(gradient.dot(direction), 0.98) << "r " << r;
    }
    const double deep = grid.distance(0.005 * direction);
    EXPECT_LT(deep, -0.015 * 0.999);
    EXPECT_GT(deep, -0.015 * 1.1);
  }
  EXPECT_LT(grid.distance(Eigen::Vector3d::Zero()), -0.019);
  // Outside the grid the value keeps growing with the distance.
  EXPECT_NEAR(grid.distance(Eigen::Vector3d(0.2, 0, 0)), 0.18, 0.01);
}

TEST(SignedDistanceGrid, IsExactForABoxFaceAndSignsTheCorners) {
  const Mesh block = sim::box(Eigen::Vector3d(0.03, 0.01, 0.02));
  const SignedDistanceGrid grid(block);
  EXPECT_NEAR(grid.distance(Eigen::Vector3d(0.004, 0.0085, -0.003)), -0.0015, 1e-7);
  EXPECT_NEAR(grid.distance(Eigen::Vector3d(0.004, 0.0115, -0.003)), 0.0015, 1e-7);
  // Just outside an edge and just inside a corner: signs from the pseudonormals.
  EXPECT_GT(grid.distance(Eigen::Vector3d(0.0305, 0.0105, 0.0)), 0.0);
  EXPECT_LT(grid.distance(Eigen::Vector3d(0.0295, 0.0095, 0.0195)), 0.0);
}

// Anywhere outside the box the distance is at least outsideLowerBound(), which is about the
// margin (callers skip points outside the box that they would drop as too far anyway).
TEST(SignedDistanceGrid, OutsideTheBoxTheDistanceIsAtLeastItsLowerBound) {
  const Mesh block = sim::box(Eigen::Vector3d(0.03, 0.01, 0.02));
  SignedDistanceGridSettings settings;
  settings.margin_m = 0.006;
  const SignedDistanceGrid grid(block, settings);
  const double bound = grid.outsideLowerBound();
  EXPECT_GT(bound, 0.5 * settings.margin_m);
  EXPECT_LT(bound, settings.margin_m + settings.spacing_m);
  const Eigen::Vector3d centre = grid.box().center();
  const Eigen::Vector3d half = 0.5 * grid.box().sizes();
  int outside = 0;
  for (int i = 0; i < 2000; ++i) {
    // Points on and beyond the box's faces, edges and corners, up to 3 mm out.
    const Eigen::Vector3d unit = Eigen::Vector3d::Random();
    const Eigen::Vector3d p =
        centre + unit.cwiseProduct(half + Eigen::Vector3d::Constant(0.003 * std::abs(unit.x())));
    if (grid.contains(p)) continue;
    ++outside;
    EXPECT_GE(grid.distance(p), bound) << p.transpose();
  }
  EXPECT_GT(outside, 100);
}

TEST(SignedDistanceGrid, RejectsBadSettingsAndEmptyMeshes) {
  SignedDistanceGridSettings settings;
  settings.exact_band_m = settings.spacing_m;
  EXPECT_THROW_WITH(SignedDistanceGrid(sim::box(Eigen::Vector3d::Constant(0.01)), settings),
                    "exact_band_m");
  EXPECT_THROW_WITH(SignedDistanceGrid{Mesh{}}, "empty");
}

}  // namespace
}  // namespace geometry
}  // namespace fluoro_tracker
