#include "fluoro_tracker/imaging/edge_map.h"

#include <opencv2/imgproc.hpp>

#include "../test_support.h"

using namespace fluoro_tracker;
using imaging::EdgeMap;

namespace {

const geometry::XrayCamera kCamera(200, 160, 1000.0, 1000.0, 99.5, 79.5);

// A dark disc of radius 30 px centred at (100, 80) on a bright background.
cv::Mat disc(bool bright_implant, int type = CV_8U) {
  cv::Mat image(160, 200, type, cv::Scalar(bright_implant ? 40 : 200) * (type == CV_16U ? 256 : 1));
  cv::circle(image, cv::Point(100 * 16, 80 * 16), 30 * 16,
             cv::Scalar(bright_implant ? 200 : 40) * (type == CV_16U ? 256 : 1), cv::FILLED,
             cv::LINE_AA, 4);
  return image;
}

}  // namespace

TEST(EdgeMap, EdgesLieOnTheBoundaryInEitherPolarityAndBitDepth) {
  for (bool bright : {false, true}) {
    for (int type : {CV_8U, CV_16U}) {
      const EdgeMap map(disc(bright, type), kCamera, imaging::EdgeMapSettings());
      double d = 0.0;
      double du = 0.0;
      double dv = 0.0;
      for (int k = 0; k < 16; ++k) {
        const double a = 2.0 * M_PI * k / 16;
        ASSERT_TRUE(map.sample(100 + 30 * std::cos(a), 80 + 30 * std::sin(a), &d, &du, &dv));
        EXPECT_LE(d, 1.0) << "bright " << bright << " angle " << a;  // pixel-accurate edges
      }
      // 10 px inside the disc the nearest edge is ~10 px away, and the distance grows inward.
      ASSERT_TRUE(map.sample(120.0, 80.0, &d, &du, &dv));
      EXPECT_NEAR(d, 10.0, 1.0);
      EXPECT_LT(du, -0.5);
    }
  }
}

TEST(EdgeMap, RegionAndScaleKeepPixelsConsistentWithTheCamera) {
  const EdgeMap map(disc(false), kCamera, imaging::EdgeMapSettings(), cv::Rect(40, 20, 120, 120),
                    0.5);
  EXPECT_EQ(map.camera().width(), 60);
  EXPECT_EQ(map.camera().height(), 60);
  // The disc's right-most boundary point, projected with the map's camera, is on an edge.
  const Eigen::Vector3d point_on_boundary((130.0 - 99.5) / 1000.0, (80.0 - 79.5) / 1000.0, 1.0);
  Eigen::Vector2d px;
  ASSERT_TRUE(map.camera().project(point_on_boundary, &px));
  double d = 0.0;
  double du = 0.0;
  double dv = 0.0;
  ASSERT_TRUE(map.sample(px.x(), px.y(), &d, &du, &dv));
  EXPECT_LE(d, 1.0);
  EXPECT_FALSE(map.sample(-5.0, 10.0, &d, &du, &dv));
  EXPECT_EQ(d, imaging::EdgeMapSettings().max_distance_px);
}

TEST(EdgeMap, BadImagesNameTheProblem) {
  EXPECT_THROW_WITH(EdgeMap(cv::Mat(), kCamera, imaging::EdgeMapSettings()), "is empty");
  EXPECT_THROW_WITH(EdgeMap(cv::Mat::zeros(100, 100, CV_8U), kCamera, imaging::EdgeMapSettings()),
                    "camera_info says 200x160");
  EXPECT_THROW_WITH(EdgeMap(cv::Mat::zeros(160, 200, CV_32F), kCamera, imaging::EdgeMapSettings()),
                    "8- or 16-bit");
}
