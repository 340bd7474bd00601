#include "fluoro_tracker/imaging/lens_distortion.h"

#include <opencv2/imgproc.hpp>

#include "../test_support.h"

using namespace fluoro_tracker;
using imaging::LensDistortion;

namespace {

// A smooth test card: a disc and a bar on a 256 x 256 frame, blurred so that interpolation
// error stays small next to the distortion's displacement.
cv::Mat testCard() {
  cv::Mat card(256, 256, CV_8UC1, cv::Scalar(200));
  cv::circle(card, cv::Point(150, 110), 40, cv::Scalar(40), cv::FILLED);
  cv::rectangle(card, cv::Rect(40, 170, 150, 25), cv::Scalar(90), cv::FILLED);
  cv::GaussianBlur(card, card, cv::Size(0, 0), 2.0);
  return card;
}

double meanAbsoluteDifference(const cv::Mat& a, const cv::Mat& b) {
  const cv::Rect inner(32, 32, 192, 192);
  cv::Mat difference;
  cv::absdiff(a(inner), b(inner), difference);
  return cv::mean(difference)[0];
}

}  // namespace

// Each model's distortion, put on a frame and taken off again, returns the frame; the distorted
// frame itself differs.
TEST(LensDistortion, RemovingUndoesApplyingForEveryModel) {
  const geometry::XrayCamera camera(256, 256, 400.0, 400.0, 127.5, 127.5, "fluoro_optical");
  const cv::Mat card = testCard();
  for (const LensDistortion& lens :
       {LensDistortion{"plumb_bob", {0.6, 0.0, 0.002, -0.001, 0.0}},
        LensDistortion{"rational_polynomial", {0.5, 0.1, 0.0, 0.0, 0.0, 0.05, 0.0, 0.0}},
        LensDistortion{"equidistant", {1.0, 0.0, 0.0, 0.0}}}) {
    EXPECT_TRUE(lens.distorts());
    const cv::Mat distorted = imaging::applyLensDistortion(card, camera, lens);
    const cv::Mat restored =
        imaging::remapThroughLens(distorted, imaging::undistortionMaps(camera, lens));
    ASSERT_EQ(restored.size(), card.size());
    const double before = meanAbsoluteDifference(distorted, card);
    const double after = meanAbsoluteDifference(restored, card);
    EXPECT_GT(before, 1.0) << lens.model;
    EXPECT_LT(after, 0.25 * before) << lens.model << ": before " << before << ", after " << after;
  }
}

TEST(LensDistortion, NoCoefficientsNoChangeAndBadOnesNamed) {
  const geometry::XrayCamera camera(64, 64, 100.0, 100.0, 31.5, 31.5, "fluoro_optical");
  const cv::Mat card = testCard()(cv::Rect(0, 0, 64, 64)).clone();
  const LensDistortion none{"plumb_bob", {0.0, 0.0, 0.0, 0.0, 0.0}};
  EXPECT_FALSE(none.distorts());
  EXPECT_EQ(cv::norm(imaging::applyLensDistortion(card, camera, none), card, cv::NORM_INF), 0.0);
  EXPECT_NO_THROW(LensDistortion{}.validate("view"));
  // A fisheye's projection is not the pinhole's even without coefficients.
  EXPECT_TRUE((LensDistortion{"equidistant", {0.0, 0.0, 0.0, 0.0}}.distorts()));
  EXPECT_THROW_WITH((LensDistortion{"barrel", {0.1}}.validate("view")),
                    "view has distortion model 'barrel'");
  EXPECT_THROW_WITH((LensDistortion{"equidistant", {0.1, 0.0}}.validate("view")),
                    "4 distortion coefficients, not 2");
  EXPECT_THROW_WITH(
      (LensDistortion{"plumb_bob", {0.0, 0.0, 0.0, 0.0, std::nan("")}}.validate("view")),
      "non-finite");
}
