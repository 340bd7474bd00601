#include "fluoro_tracker/registration/corner_rounding.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using namespace fluoro_tracker;
using registration::cornerRounding;

namespace {

// Samples every pixel (at half-pixel positions) along the segment from `from` to `to`, with
// `normal` pointing out of the silhouette.
void addEdge(const Eigen::Vector2d& from, const Eigen::Vector2d& to, const Eigen::Vector2d& normal,
             std::vector<imaging::ContourPoint>* contour) {
  const double length = (to - from).norm();
  for (double s = 0.5; s < length; s += 1.0) {
    imaging::ContourPoint p;
    p.model_point = Eigen::Vector3d::Zero();
    p.pixel = from + (to - from) * (s / length);
    p.normal = normal;
    contour->push_back(p);
  }
}

double normalCdf(double x) {
  return 0.5 * std::erfc(-x / std::sqrt(2.0));
}

// The outline of the square [0, 40] x [0, 40] (image axes), normals outward.
std::vector<imaging::ContourPoint> square() {
  std::vector<imaging::ContourPoint> contour;
  addEdge({0, 0}, {40, 0}, {0, -1}, &contour);
  addEdge({40, 0}, {40, 40}, {1, 0}, &contour);
  addEdge({40, 40}, {0, 40}, {0, 1}, &contour);
  addEdge({0, 40}, {0, 0}, {-1, 0}, &contour);
  return contour;
}

}  // namespace

TEST(CornerRounding, LeavesStraightOutlineAndNoBlurAlone) {
  const auto contour = square();
  for (const double r : cornerRounding(contour, 0.0)) EXPECT_EQ(r, 0.0);
  const auto rounding = cornerRounding(contour, 1.0);
  ASSERT_EQ(rounding.size(), contour.size());
  for (std::size_t i = 0; i < contour.size(); ++i) {
    const Eigen::Vector2d& p = contour[i].pixel;
    const double to_corner =
        std::min(std::min(p.x(), 40.0 - p.x()) + std::min(p.y(), 40.0 - p.y()), 100.0);
    if (to_corner > 3.5) {
      EXPECT_EQ(rounding[i], 0.0) << "sample at " << p.transpose();
    }
  }
}

// At a convex right-angled corner the half level of the blurred square, along a sample's
// normal, lies a = s Phi^-1(0.5 / Phi(b / s)) inside, b the sample's distance from the other
// side: largest at the vertex (capped at sigma), falling to nothing within 3 sigma.
TEST(CornerRounding, ExpectsEdgesInsideConvexCorners) {
  const auto contour = square();
  const double sigma = 1.0;
  const auto rounding = cornerRounding(contour, sigma);
  for (std::size_t i = 0; i < contour.size(); ++i) {
    const Eigen::Vector2d& p = contour[i].pixel;
    if (contour[i].normal.y() != -1.0 || p.x() > 3.0) continue;  // the top edge by (0, 0)
    const double b = p.x();                                      // distance from the left side
    // Phi^-1 by bisection, independent of the implementation's.
    const double level = 0.5 / normalCdf(b / sigma);
    double lo = 0.0;
    double hi = 10.0;
    for (int k = 0; k < 100; ++k) {
      const double mid = 0.5 * (lo + hi);
      (normalCdf(mid) < level ? lo : hi) = mid;
    }
    const double expected = std::min(sigma, sigma * 0.5 * (lo + hi));
    EXPECT_NEAR(rounding[i], expected, 1e-6) << "sample at " << p.transpose();
    EXPECT_GT(rounding[i], 0.0);
    EXPECT_LE(rounding[i], sigma);
  }
  // Nearer the vertex, farther inside.
  EXPECT_GT(rounding[0], rounding[1]);
  EXPECT_GT(rounding[1], rounding[2]);
}

// At a concave corner (the L-shaped silhouette {x <= 20} u {y >= 20}) the edge passes outside.
TEST(CornerRounding, ExpectsEdgesOutsideConcaveCorners) {
  std::vector<imaging::ContourPoint> contour;
  addEdge({20, 0}, {20, 20}, {1, 0}, &contour);    // the vertical side, silhouette to the left
  addEdge({20, 20}, {40, 20}, {0, -1}, &contour);  // the horizontal side, silhouette below
  const auto rounding = cornerRounding(contour, 1.0);
  // The samples by the vertex (20, 20): the last of the first side, the first of the second.
  const std::size_t last_vertical = 19;
  const std::size_t first_horizontal = 20;
  EXPECT_LT(rounding[last_vertical], 0.0);
  EXPECT_LT(rounding[first_horizontal], 0.0);
  EXPECT_NEAR(rounding[last_vertical], rounding[first_horizontal], 1e-12);
  EXPECT_EQ(rounding[0], 0.0);  // 20 px from the vertex
  EXPECT_GE(rounding[last_vertical], -1.0);
}

// A part wider than the search reach shows no rounding between its parallel sides.
TEST(CornerRounding, IgnoresTheFarSideOfAWidePart) {
  std::vector<imaging::ContourPoint> contour;
  addEdge({0, 0}, {40, 0}, {0, -1}, &contour);
  addEdge({40, 5}, {0, 5}, {0, 1}, &contour);  // 5 px below, facing the other way
  const auto rounding = cornerRounding(contour, 1.0);
  for (const double r : rounding) EXPECT_EQ(r, 0.0);
}
