#include "fluoro_tracker/imaging/detector_model.h"

#include "../test_support.h"

using namespace fluoro_tracker;
using imaging::DetectorSettings;

namespace {

DetectorSettings ideal() {
  DetectorSettings s;
  s.photons_per_pixel = 0.0;
  s.blur_sigma_px = 0.0;
  s.scatter_strength = 0.0;
  s.window_min_attenuation = 0.0;
  s.window_max_attenuation = 4.0;
  return s;
}

}  // namespace

TEST(DetectorModel, NoiseFreeFrameFollowsBeerLambertThroughTheWindow) {
  cv::Mat a(1, 5, CV_64F);
  const double values[5] = {0.0, 1.0, 2.0, 4.0, 9.0};
  for (int i = 0; i < 5; ++i) a.at<double>(0, i) = values[i];
  std::mt19937_64 rng(1);
  DetectorSettings s = ideal();
  s.bit_depth = 16;
  const cv::Mat dark = imaging::formRadiograph(a, s, &rng);
  ASSERT_EQ(dark.type(), CV_16U);
  // Measured attenuation -ln(exp(-A)) = A, windowed 0..4 onto 65535..0.
  for (int i = 0; i < 5; ++i) {
    const double expected = 65535.0 * (1.0 - std::min(values[i], 4.0) / 4.0);
    EXPECT_NEAR(dark.at<std::uint16_t>(0, i), expected, 1.0) << "A = " << values[i];
  }
  s.implants_bright = true;
  s.bit_depth = 8;
  const cv::Mat bright = imaging::formRadiograph(a, s, &rng);
  ASSERT_EQ(bright.type(), CV_8U);
  EXPECT_EQ(bright.at<std::uint8_t>(0, 0), 0);
  EXPECT_NEAR(bright.at<std::uint8_t>(0, 2), 127.5, 1.0);
  EXPECT_EQ(bright.at<std::uint8_t>(0, 4), 255);
}

TEST(DetectorModel, QuantumNoiseHasThePoissonSpreadAndTheSeedFixesIt) {
  const cv::Mat a = cv::Mat(200, 200, CV_64F, cv::Scalar(1.0));
  DetectorSettings s = ideal();
  s.photons_per_pixel = 10000.0;
  s.bit_depth = 16;
  std::mt19937_64 rng1(5);
  std::mt19937_64 rng2(5);
  const cv::Mat f1 = imaging::formRadiograph(a, s, &rng1);
  const cv::Mat f2 = imaging::formRadiograph(a, s, &rng2);
  EXPECT_EQ(cv::norm(f1, f2, cv::NORM_INF), 0.0);
  // Counts N = N0 e^-1 = 3679: the measured attenuation spreads by 1/sqrt(N) = 0.0165, which is
  // 0.0165 / 4 * 65535 = 270 grey levels.
  cv::Scalar mean;
  cv::Scalar stddev;
  cv::meanStdDev(f1, mean, stddev);
  EXPECT_NEAR(stddev[0], 65535.0 / 4.0 / std::sqrt(10000.0 * std::exp(-1.0)), 15.0);
  EXPECT_NEAR(mean[0], 65535.0 * 0.75, 30.0);
}

TEST(DetectorModel, BlurSpreadsAnEdgeAndCollimatorDarkensCorners) {
  cv::Mat a = cv::Mat::zeros(64, 64, CV_64F);
  a(cv::Rect(32, 0, 32, 64)) = 3.0;
  DetectorSettings s = ideal();
  s.blur_sigma_px = 2.0;
  std::mt19937_64 rng(1);
  const cv::Mat blurred = imaging::formRadiograph(a, s, &rng);
  const int left = blurred.at<std::uint8_t>(32, 30);
  const int right = blurred.at<std::uint8_t>(32, 33);
  EXPECT_LT(left, 255);
  EXPECT_GT(right, static_cast<int>(255 * (1.0 - 3.0 / 4.0)) + 2);

  s.blur_sigma_px = 0.0;
  s.collimator_radius_fraction = 0.9;
  const cv::Mat collimated = imaging::formRadiograph(cv::Mat::zeros(64, 64, CV_64F), s, &rng);
  EXPECT_EQ(collimated.at<std::uint8_t>(0, 0), 0);
  EXPECT_EQ(collimated.at<std::uint8_t>(32, 32), 255);
}

TEST(DetectorModel, ScatterFollowsTheSingleScatterModel) {
  // Tissue (A = 2.5) with an opaque metal block in the middle and open air at the left edge.
  cv::Mat a(256, 256, CV_64F, cv::Scalar(2.5));
  a(cv::Rect(112, 112, 32, 32)) = 20.0;
  a(cv::Rect(0, 0, 12, 256)) = 0.0;
  DetectorSettings s = ideal();
  s.bit_depth = 16;
  s.window_max_attenuation = 10.0;
  s.pixel_spacing_mm = 1.0;
  s.scatter_sigma_mm = 20.0;
  std::mt19937_64 rng(1);
  const auto measured = [&](const cv::Mat& frame, int row, int col) {
    return 10.0 * (1.0 - frame.at<std::uint16_t>(row, col) / 65535.0);
  };
  const cv::Mat without = imaging::formRadiograph(a, s, &rng);
  EXPECT_NEAR(measured(without, 128, 128), 10.0, 1e-3);  // clipped: no photons behind metal
  EXPECT_NEAR(measured(without, 200, 200), 2.5, 1e-3);
  s.scatter_strength = 0.2;
  const cv::Mat with = imaging::formRadiograph(a, s, &rng);
  // Far from metal and air the scatter-to-primary ratio is strength x A = 0.5.
  EXPECT_NEAR(measured(with, 220, 200), 2.5 - std::log(1.5), 0.05);
  // Behind the metal only scatter arrives: dark, but not clipped.
  EXPECT_GT(measured(with, 128, 128), 2.5);
  EXPECT_LT(measured(with, 128, 128), 6.0);
  // Open air generates no scatter; it only receives a little from the tissue beside it.
  EXPECT_LT(measured(with, 128, 2), 0.0 + 1e-9);
}

TEST(DetectorModel, InvalidSettingsAreNamed) {
  DetectorSettings s;
  s.bit_depth = 12;
  EXPECT_THROW_WITH(s.validate(), "bit_depth");
  s = DetectorSettings();
  s.window_max_attenuation = s.window_min_attenuation;
  EXPECT_THROW_WITH(s.validate(), "window_max_attenuation");
}
