#include "fluoro_tracker/registration/edge_map_prefetch.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "../test_support.h"

using namespace fluoro_tracker;
using registration::EdgeMapPrefetch;

namespace {

const geometry::XrayCamera kCamera(240, 200, 1000.0, 1000.0, 119.5, 99.5);

// A dark disc and a darker bar on a bright background: edges in several directions.
registration::ViewImage frame() {
  cv::Mat image(kCamera.height(), kCamera.width(), CV_8U, cv::Scalar(200));
  cv::circle(image, cv::Point(110, 95), 45, cv::Scalar(60), cv::FILLED, cv::LINE_AA);
  cv::rectangle(image, cv::Point(150, 30), cv::Point(175, 170), cv::Scalar(30), cv::FILLED);
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.8);
  return {image, kCamera};
}

// The same edges and the same signed distances, sampled off the pixel grid.
void expectSameMap(const imaging::EdgeMap& a, const imaging::EdgeMap& b) {
  ASSERT_EQ(a.edges().size(), b.edges().size());
  EXPECT_EQ(cv::countNonZero(a.edges() != b.edges()), 0);
  EXPECT_GT(cv::countNonZero(a.edges()), 20);
  for (double v = 2.3; v < a.edges().rows - 2; v += 7.1) {
    for (double u = 2.7; u < a.edges().cols - 2; u += 6.3) {
      double da = 0.0, db = 0.0, gu = 0.0, gv = 0.0;
      a.sample(u, v, &da, &gu, &gv);
      b.sample(u, v, &db, &gu, &gv);
      EXPECT_EQ(da, db) << u << ", " << v;
    }
  }
}

}  // namespace

TEST(EdgeMapPrefetch, GivesTheMapsBuiltDirectlyWithOrWithoutAThread) {
  const std::vector<registration::ViewImage> views = {frame()};
  const std::vector<cv::Rect> rois = {cv::Rect(40, 20, 170, 170)};
  const std::vector<double> scales = {0.25, 0.5, 1.0};
  const imaging::EdgeMapSettings settings;
  for (bool background : {true, false}) {
    EdgeMapPrefetch prefetch(views, settings, rois, scales, background);
    for (std::size_t k = 0; k < scales.size(); ++k) {
      const std::vector<imaging::EdgeMap> maps = prefetch.take(k);
      ASSERT_EQ(maps.size(), 1u);
      const imaging::EdgeMap direct(views[0].image, views[0].camera, settings, rois[0], scales[k]);
      EXPECT_EQ(maps[0].roi(), direct.roi());
      EXPECT_EQ(maps[0].scale(), scales[k]);
      expectSameMap(maps[0], direct);
    }
  }
}

TEST(EdgeMapPrefetch, PassesOnWhatBuildingAMapThrew) {
  registration::ViewImage wrong = frame();
  cv::resize(wrong.image, wrong.image, cv::Size(120, 100));  // its camera says 240 x 200
  const std::vector<registration::ViewImage> views = {wrong};
  const std::vector<cv::Rect> rois = {cv::Rect()};
  for (bool background : {true, false}) {
    EdgeMapPrefetch prefetch(views, imaging::EdgeMapSettings(), rois, {0.5, 1.0}, background);
    EXPECT_THROW_WITH(prefetch.take(1), "camera_info says 240x200");
    EXPECT_THROW_WITH(prefetch.take(0), "camera_info says 240x200");
  }
}

TEST(EdgeMapPrefetch, MayBeDroppedWithMapsNotTaken) {
  const std::vector<registration::ViewImage> views = {frame(), frame()};
  const std::vector<cv::Rect> rois = {cv::Rect(), cv::Rect()};
  {
    EdgeMapPrefetch prefetch(views, imaging::EdgeMapSettings(), rois, {0.25, 0.5, 1.0}, true);
    EXPECT_EQ(prefetch.take(0).size(), 2u);
  }  // the builder stops and is joined (a hang here fails the test by its time limit)
  EdgeMapPrefetch untouched(views, imaging::EdgeMapSettings(), rois, {0.5, 1.0}, true);
}
