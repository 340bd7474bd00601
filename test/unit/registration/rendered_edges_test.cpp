#include "fluoro_tracker/registration/rendered_edges.h"

#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>
#include <vector>

#include "fluoro_tracker/sim/mesh_builder.h"

using namespace fluoro_tracker;
using registration::renderedEdgeRounding;

namespace {

// 1500 px focal length, the meshes 0.5 m from the source: 3 px per mm.
const geometry::XrayCamera& camera() {
  static const geometry::XrayCamera c(512, 512, 1500.0, 1500.0, 255.5, 255.5);
  return c;
}

geometry::Pose halfAMetreAway() {
  geometry::Pose pose = geometry::Pose::Identity();
  pose.translation() = Eigen::Vector3d(0.0, 0.0, 0.5);
  return pose;
}

}  // namespace

// A block seen face-on, turned 10 deg about the beam, projects to a rectangle whose sides cross
// the pixel grid at an angle; its depth (10 mm) saturates the grey. Along its sides the rendered
// edges lie on the outline (single samples within a pixel's rendering, the mean within a tenth of
// a pixel), and its corners are cut, as the edge map's smoothing cuts them.
TEST(RenderedEdgeRounding, FollowsStraightSidesAndCutsCorners) {
  const geometry::Mesh block = sim::box(Eigen::Vector3d(0.02, 0.01, 0.005));
  const imaging::SilhouetteModel model(block);
  geometry::Pose pose = halfAMetreAway();
  const double turn = 10.0 * M_PI / 180.0;
  pose.linear() = Eigen::AngleAxisd(turn, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto contour = model.contour(camera(), pose, 1.0);
  ASSERT_GT(contour.size(), 300u);
  const auto rounding =
      renderedEdgeRounding(model, camera(), pose, contour, imaging::EdgeMapSettings(), 1.0);
  ASSERT_EQ(rounding.size(), contour.size());
  // The near face's outline: 40 x 20 mm at 495 mm, i.e. half-sides of 60.6 and 30.3 px.
  const double scale = 1500.0 / 495.0;
  double side_sum = 0.0;
  double side_squares = 0.0;
  int sides = 0;
  std::vector<double> at_corners;
  for (std::size_t i = 0; i < contour.size(); ++i) {
    const Eigen::Vector2d p =
        Eigen::Rotation2Dd(-turn) * (contour[i].pixel - Eigen::Vector2d(255.5, 255.5));
    const double to_corner =
        std::hypot(std::abs(p.x()) - 20.0 * scale, std::abs(p.y()) - 10.0 * scale);
    if (to_corner > 5.0) {
      side_sum += rounding[i];
      side_squares += rounding[i] * rounding[i];
      ++sides;
    } else if (to_corner < 1.0) {
      at_corners.push_back(rounding[i]);
    }
  }
  ASSERT_GT(sides, 250);
  const double side_mean = side_sum / sides;
  EXPECT_NEAR(side_mean, 0.0, 0.1);
  EXPECT_LT(std::sqrt(side_squares / sides - side_mean * side_mean), 0.15);
  ASSERT_GE(at_corners.size(), 4u);
  for (const double r : at_corners) EXPECT_GT(r, side_mean + 0.2);
}

// A sphere's path length rises from nothing at its rim: the more metal the display needs to
// saturate, the farther inside the rim the edge map finds the edge.
TEST(RenderedEdgeRounding, ThinRimsMoveTheEdgeInwardAsSaturationNeedsMoreMetal) {
  const geometry::Mesh ball = sim::uvSphere(0.01);
  const imaging::SilhouetteModel model(ball);
  const geometry::Pose pose = halfAMetreAway();
  const auto contour = model.contour(camera(), pose, 1.0);
  ASSERT_GT(contour.size(), 100u);
  const auto mean = [&](double saturation_mm) {
    const auto rounding = renderedEdgeRounding(model, camera(), pose, contour,
                                               imaging::EdgeMapSettings(), saturation_mm);
    double sum = 0.0;
    for (const double r : rounding) sum += r;
    return sum / static_cast<double>(rounding.size());
  };
  const double sharp = mean(0.5);
  const double soft = mean(8.0);
  EXPECT_GE(sharp, -0.1);
  EXPECT_GT(soft, sharp + 0.2);
}

// Nothing to render (the mesh behind the source) leaves every sample as it is.
TEST(RenderedEdgeRounding, LeavesSamplesAloneWhenTheModelCannotBeRendered) {
  const geometry::Mesh block = sim::box(Eigen::Vector3d(0.02, 0.01, 0.005));
  const imaging::SilhouetteModel model(block);
  const auto contour = model.contour(camera(), halfAMetreAway(), 1.0);
  ASSERT_FALSE(contour.empty());
  geometry::Pose behind = geometry::Pose::Identity();
  behind.translation() = Eigen::Vector3d(0.0, 0.0, -0.5);
  for (const double r :
       renderedEdgeRounding(model, camera(), behind, contour, imaging::EdgeMapSettings(), 1.0)) {
    EXPECT_EQ(r, 0.0);
  }
}
