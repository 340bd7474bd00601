#include "fluoro_tracker/imaging/renderer.h"

#include "../test_support.h"
#include "fluoro_tracker/sim/implant_models.h"
#include "fluoro_tracker/sim/mesh_builder.h"

using namespace fluoro_tracker;
using geometry::Pose;
using geometry::XrayCamera;
using imaging::Renderer;

namespace {

const XrayCamera kCamera(256, 256, 3000.0, 3000.0, 127.5, 127.5);

// Exact length of a ray from the origin along unit d inside an oriented box (slab method).
double boxChord(const Eigen::Vector3d& d, const Pose& camera_from_box,
                const Eigen::Vector3d& half) {
  const Pose box_from_camera = camera_from_box.inverse();
  const Eigen::Vector3d o = box_from_camera.translation();
  const Eigen::Vector3d dir = box_from_camera.linear() * d;
  double t0 = -1e9;
  double t1 = 1e9;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(dir[k]) < 1e-15) {
      if (std::abs(o[k]) > half[k]) return 0.0;
      continue;
    }
    double a = (-half[k] - o[k]) / dir[k];
    double b = (half[k] - o[k]) / dir[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return std::max(0.0, t1 - t0);
}

}  // namespace

TEST(Renderer, PathLengthThroughASphereMatchesTheChord) {
  const double radius = 0.006;  // 6 mm at 1 m: ~36 px across
  const Eigen::Vector3d centre(0.001, -0.002, 1.0);
  const geometry::Mesh sphere = sim::uvSphere(radius, 96, 192);
  const cv::Mat length = Renderer::pathLength(
      kCamera, sphere, geometry::makePose(Eigen::Matrix3d::Identity(), centre));
  int checked = 0;
  double worst = 0.0;
  for (int v = 0; v < kCamera.height(); ++v) {
    for (int u = 0; u < kCamera.width(); ++u) {
      const Eigen::Vector3d d = kCamera.backProject(
          Eigen::Vector2d(u + Renderer::kSampleOffsetPx, v + Renderer::kSampleOffsetPx));
      const double distance = (centre - centre.dot(d) * d).norm();
      const double rendered = length.at<double>(v, u);
      if (distance > radius * 1.001) {
        EXPECT_EQ(rendered, 0.0) << "outside the sphere at " << u << "," << v;
      } else if (distance < 0.95 * radius) {
        const double exact = 2.0 * std::sqrt(radius * radius - distance * distance);
        worst = std::max(worst, std::abs(rendered - exact) / radius);
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 500);
  // An inscribed polyhedron of 96 x 192 facets is within ~0.2 % of the radius of the sphere.
  EXPECT_LT(worst, 0.003);
}

TEST(Renderer, PathLengthThroughARotatedBoxIsExact) {
  const Eigen::Vector3d half(0.004, 0.006, 0.010);
  const Pose pose = geometry::makePose(
      Eigen::AngleAxisd(0.5, Eigen::Vector3d(1.0, 2.0, 0.5).normalized()).toRotationMatrix(),
      Eigen::Vector3d(-0.002, 0.003, 0.95));
  const cv::Mat length = Renderer::pathLength(kCamera, sim::box(half), pose);
  double worst = 0.0;
  double covered = 0.0;
  for (int v = 0; v < kCamera.height(); ++v) {
    for (int u = 0; u < kCamera.width(); ++u) {
      const double exact =
          boxChord(kCamera.backProject(Eigen::Vector2d(u + Renderer::kSampleOffsetPx,
                                                       v + Renderer::kSampleOffsetPx)),
                   pose, half);
      worst = std::max(worst, std::abs(length.at<double>(v, u) - exact));
      if (exact > 0.0) ++covered;
    }
  }
  EXPECT_GT(covered, 1000);
  // Exact up to the 1/256-pixel snapping of vertices at the silhouette (where chords -> 0).
  EXPECT_LT(worst, 2e-5);
}

TEST(Renderer, EdgesSharedByTrianglesAreCountedOnce) {
  // A box whose front face's diagonal passes exactly through the pixels' sample points
  // (u + d, u + d): a double-counted or missed shared edge would show as a line of wrong
  // lengths.
  const double depth = 1.0;
  const double half_px = 20.0;
  const double half = half_px * depth / kCamera.fx();
  // Front face at z = depth with its corners on pixel centres (128 +- 20).
  const Eigen::Vector3d centre(0.5 * depth / kCamera.fx(), 0.5 * depth / kCamera.fy(),
                               depth + 0.01);
  const Eigen::Vector3d h(half, half, 0.01);
  const Pose pose = geometry::makePose(Eigen::Matrix3d::Identity(), centre);
  const cv::Mat length = Renderer::pathLength(kCamera, sim::box(h), pose);
  for (int v = 100; v < 156; ++v) {
    for (int u = 100; u < 156; ++u) {
      const double exact =
          boxChord(kCamera.backProject(Eigen::Vector2d(u + Renderer::kSampleOffsetPx,
                                                       v + Renderer::kSampleOffsetPx)),
                   pose, h);
      EXPECT_NEAR(length.at<double>(v, u), exact, 1e-9) << u << "," << v;
    }
  }
}

TEST(Renderer, LineIntegralIsTheAttenuationWeightedSum) {
  const geometry::Mesh sphere = sim::uvSphere(0.005, 24, 48);
  const Pose a = geometry::makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(-0.002, 0.0, 1.0));
  const Pose b = geometry::makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.003, 0.0, 1.1));
  const cv::Mat la = Renderer::pathLength(kCamera, sphere, a);
  const cv::Mat lb = Renderer::pathLength(kCamera, sphere, b);
  const cv::Mat sum = Renderer::lineIntegral(kCamera, {{&sphere, a, 1.0}, {&sphere, b, 0.25}});
  const cv::Mat expected = 1e3 * (1.0 * la + 0.25 * lb);  // per mm x metres
  EXPECT_LT(cv::norm(sum, expected, cv::NORM_INF), 1e-9);
  EXPECT_GT(cv::norm(sum, cv::NORM_INF), 1.0);
}

TEST(Renderer, MeshBehindTheSourceIsAnError) {
  const geometry::Mesh sphere = sim::uvSphere(0.01, 12, 24);
  EXPECT_THROW_WITH(Renderer::pathLength(kCamera, sphere,
                                         geometry::makePose(Eigen::Matrix3d::Identity(),
                                                            Eigen::Vector3d(0.0, 0.0, -0.5))),
                    "behind the X-ray source");
}

// The silhouette mask (front faces filled) covers exactly the pixels whose rays cross the mesh:
// the same pixels as a positive path length, on a non-convex part (a simulated femoral
// component, whose box cuts and condyles overlap in projection) at an oblique pose.
TEST(Renderer, CoverageIsWherePathLengthIsPositive) {
  const geometry::Mesh femur = sim::makeKneeImplants().femoral_component;
  const XrayCamera camera(320, 320, 2500.0, 2500.0, 160.0, 160.0);
  Pose pose = geometry::makePose(
      geometry::rotationX(0.4) * geometry::rotationY(-0.7) * geometry::rotationZ(0.2),
      Eigen::Vector3d(0.002, -0.003, 1.0));
  const cv::Mat mask = Renderer::coverage(camera, femur, pose);
  const cv::Mat lengths = Renderer::pathLength(camera, femur, pose);
  const cv::Mat crossed = lengths > 1e-7;
  ASSERT_EQ(mask.type(), CV_8U);
  const int covered = cv::countNonZero(mask);
  EXPECT_GT(covered, 5000);
  cv::Mat differ;
  cv::bitwise_xor(mask, crossed, differ);
  // Only samples on a silhouette rim seen exactly edge-on may disagree.
  EXPECT_LE(cv::countNonZero(differ), covered / 1000) << cv::countNonZero(differ) << " pixels";
}
