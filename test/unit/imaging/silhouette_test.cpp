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
