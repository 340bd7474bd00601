#include "fluoro_tracker/geometry/xray_camera.h"

#include "../test_support.h"

using namespace fluoro_tracker::geometry;

TEST(XrayCamera, ProjectsAgainstHandComputedPixels) {
  // Principal distance 1200 mm, 0.4 mm pixels -> f = 3000 px; principal point (511.5, 511.5).
  const XrayCamera camera(1024, 1024, 3000.0, 3000.0, 511.5, 511.5);
  Eigen::Vector2d pixel;
  ASSERT_TRUE(camera.project(Eigen::Vector3d(0.0, 0.0, 1.0), &pixel));
  EXPECT_NEAR(pixel.x(), 511.5, 1e-12);
  EXPECT_NEAR(pixel.y(), 511.5, 1e-12);
  // 10 mm right and 20 mm down at 1 m: u = 3000*0.01 + 511.5, v = 3000*0.02 + 511.5.
  ASSERT_TRUE(camera.project(Eigen::Vector3d(0.01, 0.02, 1.0), &pixel));
  EXPECT_NEAR(pixel.x(), 541.5, 1e-9);
  EXPECT_NEAR(pixel.y(), 571.5, 1e-9);
  // Twice as far: half the offset.
  ASSERT_TRUE(camera.project(Eigen::Vector3d(0.01, 0.02, 2.0), &pixel));
  EXPECT_NEAR(pixel.x(), 526.5, 1e-9);
  EXPECT_NEAR(pixel.y(), 541.5, 1e-9);
}

TEST(XrayCamera, PointsBehindTheSourceHaveNoImage) {
  const XrayCamera camera(100, 100, 300.0, 300.0, 50.0, 50.0);
  Eigen::Vector2d pixel(-1.0, -1.0);
  EXPECT_FALSE(camera.project(Eigen::Vector3d(0.0, 0.0, -1.0), &pixel));
  EXPECT_FALSE(camera.project(Eigen::Vector3d(0.1, 0.0, 0.0), &pixel));
  EXPECT_EQ(pixel, Eigen::Vector2d(-1.0, -1.0));
}

TEST(XrayCamera, BackProjectionInvertsProjection) {
  const XrayCamera camera(640, 480, 2000.0, 2100.0, 300.0, 250.0);
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(0.05, -0.03, 0.9), Eigen::Vector3d(-0.1, 0.1, 1.3)}) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera.project(p, &pixel));
    const Eigen::Vector3d ray = camera.backProject(pixel);
    EXPECT_NEAR(ray.norm(), 1.0, 1e-12);
    EXPECT_TRUE(ray.isApprox(p.normalized(), 1e-12));
  }
}

TEST(XrayCamera, FromCameraInfoRejectsUncalibratedAndBadFields) {
  const std::array<double, 9> k = {3000, 0, 511.5, 0, 3000, 511.5, 0, 0, 1};
  const XrayCamera camera = XrayCamera::fromCameraInfo(1024, 1024, k, "fluoro_optical");
  EXPECT_EQ(camera.cameraInfoK(), k);
  EXPECT_EQ(camera.frameId(), "fluoro_optical");

  std::array<double, 9> zero = k;
  zero[0] = 0.0;
  EXPECT_THROW_WITH(XrayCamera::fromCameraInfo(1024, 1024, zero, "fluoro_optical"), "K[0]");
  EXPECT_THROW_WITH(XrayCamera::fromCameraInfo(0, 1024, k, "fluoro_optical"), "image size");
  std::array<double, 9> nan = k;
  nan[2] = std::nan("");
  EXPECT_THROW_WITH(XrayCamera::fromCameraInfo(1024, 1024, nan, "fluoro_optical"), "non-finite");
}

TEST(XrayCamera, ScaledCameraMatchesAHalfResolutionImage) {
  const XrayCamera camera(1024, 1024, 3000.0, 3000.0, 511.5, 511.5);
  const XrayCamera half = camera.scaled(0.5);
  EXPECT_EQ(half.width(), 512);
  const Eigen::Vector3d p(0.02, -0.01, 1.0);
  Eigen::Vector2d full_px;
  Eigen::Vector2d half_px;
  ASSERT_TRUE(camera.project(p, &full_px));
  ASSERT_TRUE(half.project(p, &half_px));
  // cv::resize by 0.5 maps pixel centre u to (u + 0.5) / 2 - 0.5.
  EXPECT_TRUE(
      half_px.isApprox((full_px.array() + 0.5).matrix() * 0.5 - Eigen::Vector2d(0.5, 0.5), 1e-12));
}
