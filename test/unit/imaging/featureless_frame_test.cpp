#include "fluoro_tracker/imaging/featureless_frame.h"

#include <cmath>
#include <random>

#include <opencv2/imgcodecs.hpp>

#include "../test_support.h"
#include "fluoro_tracker/sim/trial_simulator.h"

using namespace fluoro_tracker;

// Independent pixel noise measures about 1 at any depth and size, with or without the area
// averaging (a little less where the reduction's factor is not whole and its weights overlap),
// and a frame of one grey level has no ratio at all: both show nothing.
TEST(FeaturelessFrame, PixelNoiseAndOneGreyLevelShowNothing) {
  cv::RNG rng(3);
  for (const int type : {CV_16U, CV_8U}) {
    for (const int size : {1024, 200}) {
      cv::Mat noise(size, size + 24, type);
      rng.fill(noise, cv::RNG::UNIFORM, 0, type == CV_16U ? 65536 : 256);
      EXPECT_NEAR(imaging::neighbourDifferenceRatio(noise), 1.0, 0.1) << type << " " << size;
      const std::string shown = imaging::featurelessFrame(noise, 0.5);
      EXPECT_NE(shown.find("pixel noise only"), std::string::npos) << shown;
      EXPECT_NE(shown.find(">= 0.50)"), std::string::npos) << shown;
      EXPECT_EQ(imaging::featurelessFrame(noise, 0.0), "");  // the test off
    }
  }
  const cv::Mat grey(512, 512, CV_16U, cv::Scalar(1000));
  EXPECT_TRUE(std::isnan(imaging::neighbourDifferenceRatio(grey)));
  EXPECT_EQ(imaging::featurelessFrame(grey, 0.5), "one grey level");
  EXPECT_THROW_WITH(imaging::neighbourDifferenceRatio(cv::Mat()), "empty image");
  EXPECT_THROW_WITH(imaging::featurelessFrame(cv::Mat(8, 8, CV_8UC3, cv::Scalar::all(1)), 0.5),
                    "single-channel");
}

// Radiographs vary over many pixels: a simulated frame in either polarity, noisy or not, and the
// real Kneel frames measure two orders of magnitude below noise; so does a real frame with
// noise as strong as its own grey-level spread added (what is left there is anatomy).
TEST(FeaturelessFrame, RadiographsShowStructure) {
  for (const bool bright : {false, true}) {
    sim::TrialSimulatorSettings settings;
    settings.motion.frames = 5;
    settings.detector.implants_bright = bright;
    const sim::TrialSimulator simulator(settings);
    std::mt19937_64 rng(2);
    const cv::Mat image = simulator.render(2, &rng).images[0];
    EXPECT_LT(imaging::neighbourDifferenceRatio(image), 0.03) << bright;
    EXPECT_EQ(imaging::featurelessFrame(image, 0.5), "") << bright;
  }
  for (const char* name : {"0160", "0170", "0180"}) {
    const cv::Mat kneel = cv::imread(
        test_support::sharedData(std::string("jointtrack_kneel/AT_K1_V1_") + name + ".tif"),
        cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(kneel.empty()) << name;
    EXPECT_LT(imaging::neighbourDifferenceRatio(kneel), 0.03) << name;
    cv::Mat grey;
    kneel.convertTo(grey, CV_32F);
    cv::Scalar mean;
    cv::Scalar deviation;
    cv::meanStdDev(grey, mean, deviation);
    cv::Mat noise(grey.size(), CV_32F);
    cv::RNG(5).fill(noise, cv::RNG::NORMAL, 0.0, deviation[0]);
    EXPECT_LT(imaging::neighbourDifferenceRatio(grey + noise), 0.5) << name;
    EXPECT_GT(imaging::neighbourDifferenceRatio(grey + noise),
              imaging::neighbourDifferenceRatio(grey))
        << name;
  }
}
