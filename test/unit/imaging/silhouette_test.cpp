#include "fluoro_tracker/imaging/silhouette.h"

#include "../test_support.h"
#include "fluoro_tracker/imaging/renderer.h"
#include "fluoro_tracker/sim/implant_models.h"
#include "fluoro_tracker/sim/mesh_builder.h"

using namespace fluoro_tracker;

namespace {
const geometry::XrayCamera kCamera(400, 400, 3000.0, 3000.0, 199.5, 199.5);
}

TEST(Silhouette, SphereContourIsTheProjectedCircleWithOutwardNormals) {
  const imaging::SilhouetteModel model(sim::uvSphere(0.01, 48, 96));
  const geometry::Pose pose =
      geometry::makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.002, 0.0, 1.0));
  const auto contour = model.contour(kCamera, pose, 1.0);
  Eigen::Vector2d centre;
  ASSERT_TRUE(kCamera.project(pose.translation(), &centre));
  // Apparent radius of a sphere: f * r / sqrt(z^2 - r^2) ~ 30 px.
  const double radius = 3000.0 * 0.01 / std::sqrt(1.0 - 1e-4);
  EXPECT_GT(contour.size(), static_cast<std::size_t>(2 * M_PI * radius * 0.8));
  for (const auto& c : contour) {
    const Eigen::Vector2d offset = c.pixel - centre;
    EXPECT_NEAR(offset.norm(), radius, 0.6);
    EXPECT_GT(c.normal.dot(offset.normalized()), 0.9);
    Eigen::Vector2d reprojected;
    ASSERT_TRUE(kCamera.project(pose * c.model_point, &reprojected));
    EXPECT_LT((reprojected - c.pixel).norm(), 1e-9);
  }
}

TEST(Silhouette, HiddenRimsOfAFemoralComponentAreDropped) {
  const sim::KneeImplantSet implants = sim::makeKneeImplants();
  const imaging::SilhouetteModel model(implants.femoral_component);
  // A lateral view: the beam along the medial-lateral axis, as in the simulator.
  Eigen::Matrix3d lateral;
  lateral << -1, 0, 0, 0, -1, 0, 0, 0, 1;
  const geometry::Pose pose =
      geometry::makePose(lateral * geometry::rotationY(0.05), Eigen::Vector3d(0.0, 0.0, 1.0));
  const auto contour = model.contour(kCamera, pose, 1.0);
  ASSERT_GT(contour.size(), 200u);
  // Every kept sample is on the boundary of the rendered silhouette: covered just inside,
  // uncovered just outside.
  const cv::Mat path = imaging::Renderer::pathLength(kCamera, implants.femoral_component, pose);
  const auto covered = [&](const Eigen::Vector2d& p) {
    return path.at<double>(static_cast<int>(std::lround(p.y())),
                           static_cast<int>(std::lround(p.x()))) > 1e-7;
  };
  int consistent = 0;
  for (const auto& c : contour) {
    if (covered(c.pixel - 2.0 * c.normal) && !covered(c.pixel + 2.0 * c.normal)) ++consistent;
  }
  EXPECT_GT(consistent, static_cast<int>(0.97 * contour.size()));
}

TEST(Silhouette, OpenMeshesAreRejected) {
  const geometry::Mesh cube = sim::box(Eigen::Vector3d(0.01, 0.01, 0.01));
  const geometry::Mesh open(
      cube.vertices(),
      std::vector<geometry::Mesh::Triangle>(cube.triangles().begin() + 1, cube.triangles().end()));
  EXPECT_THROW_WITH(imaging::SilhouetteModel{open}, "closed");
}

// The mask filled from the contour generators' winding number covers the pixels that the
// rasterised front faces cover, on a part whose condyles overlap in projection (winding 2) and
// whose box cuts fold, seen from several directions. Samples within the renderer's vertex
// snapping (1/256 px) of the outline may differ.
TEST(Silhouette, MaskIsTheRenderedCoverage) {
  const geometry::Mesh femur = sim::makeKneeImplants().femoral_component;
  const imaging::SilhouetteModel model(femur);
  Eigen::Matrix3d lateral;
  lateral << -1, 0, 0, 0, -1, 0, 0, 0, 1;
  const std::vector<Eigen::Matrix3d> rotations = {
      lateral, lateral * geometry::rotationY(0.3) * geometry::rotationX(0.2),
      geometry::rotationX(0.4) * geometry::rotationY(-0.7) * geometry::rotationZ(0.2),
      geometry::rotationY(M_PI / 2.0)};
  for (const auto& rotation : rotations) {
    const geometry::Pose pose = geometry::makePose(rotation, Eigen::Vector3d(0.001, -0.002, 1.0));
    const cv::Mat mask = model.mask(kCamera, pose);
    const cv::Mat rendered = imaging::Renderer::coverage(kCamera, femur, pose);
    ASSERT_EQ(mask.type(), CV_8U);
    ASSERT_EQ(mask.size(), rendered.size());
    const int covered = cv::countNonZero(rendered);
    EXPECT_GT(covered, 3000);
    cv::Mat differ;
    cv::bitwise_xor(mask, rendered, differ);
    EXPECT_LE(cv::countNonZero(differ), 3) << cv::countNonZero(differ) << " of " << covered;
  }
}
