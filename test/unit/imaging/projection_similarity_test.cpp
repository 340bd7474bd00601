#include "fluoro_tracker/imaging/projection_similarity.h"

#include "../test_support.h"
#include "fluoro_tracker/sim/trial_simulator.h"

using namespace fluoro_tracker;
using geometry::Pose;

TEST(NormalizedCrossCorrelation, IsOneForAffineCopiesAndMinusOneForInverses) {
  cv::Mat a(20, 20, CV_8U);
  cv::randu(a, 0, 200);
  cv::Mat b;
  a.convertTo(b, CV_8U, 0.5, 30);
  EXPECT_NEAR(imaging::normalizedCrossCorrelation(a, b), 1.0, 1e-2);  // up to rounding
  cv::Mat inverted = 255 - a;
  EXPECT_NEAR(imaging::normalizedCrossCorrelation(a, inverted), -1.0, 1e-9);
  EXPECT_EQ(imaging::normalizedCrossCorrelation(a, cv::Mat(20, 20, CV_8U, cv::Scalar(7))), 0.0);
}

// Only the mask's pixels count: images that agree inside it and disagree outside correlate
// fully with the mask and partly without; float images give what their 8-bit copies give.
TEST(NormalizedCrossCorrelation, CountsOnlyTheMasksPixelsAndTakesAnyDepth) {
  cv::Mat a(30, 40, CV_8U);
  cv::randu(a, 0, 200);
  cv::Mat b = 255 - a;
  cv::Mat mask(a.size(), CV_8U, cv::Scalar(0));
  mask(cv::Rect(5, 5, 20, 15)).setTo(255);
  a(cv::Rect(5, 5, 20, 15)).copyTo(b(cv::Rect(5, 5, 20, 15)));
  EXPECT_NEAR(imaging::normalizedCrossCorrelation(a, b, mask), 1.0, 1e-12);
  EXPECT_LT(imaging::normalizedCrossCorrelation(a, b), 0.0);
  cv::Mat fa;
  cv::Mat fb;
  a.convertTo(fa, CV_32F, 0.01);
  b.convertTo(fb, CV_64F, 3.0, -2.0);
  EXPECT_NEAR(imaging::normalizedCrossCorrelation(fa, fb),
              imaging::normalizedCrossCorrelation(a, b), 1e-9);
  EXPECT_EQ(imaging::normalizedCrossCorrelation(a, b, cv::Mat(a.size(), CV_8U, cv::Scalar(0))),
            0.0);
}

// Both halves of the metric peak at the true pose of a simulated frame and fall with offset,
// in either polarity.
TEST(ProjectionSimilarity, IsHighestAtTheTruePoseAndFallsWithOffset) {
  for (bool bright : {false, true}) {
    sim::TrialSimulatorSettings settings;
    settings.motion.frames = 5;
    settings.detector.implants_bright = bright;
    const sim::TrialSimulator simulator(settings);
    std::mt19937_64 rng(2);
    const auto frame = simulator.render(2, &rng);
    const imaging::EdgeMap map(frame.images[0], simulator.views()[0].camera,
                               imaging::EdgeMapSettings(), cv::Rect(250, 250, 520, 520));
    const std::vector<const geometry::Mesh*> meshes = {&simulator.implants().femoral_component,
                                                       &simulator.implants().tibial_tray};
    const auto at = [&](double dx_m) {
      Pose femur = frame.femur;
      Pose tibia = frame.tibia;
      femur.translation().x() += dx_m;
      tibia.translation().x() += dx_m;
      return imaging::projectionSimilarity(map, meshes, {femur, tibia});
    };
    const auto truth = at(0.0);
    const auto near = at(0.001);
    const auto far = at(0.004);
    EXPECT_GT(truth.grey, 0.5) << "bright " << bright;
    EXPECT_GT(truth.grey, near.grey) << "bright " << bright;
    EXPECT_GT(near.grey, far.grey) << "bright " << bright;
    EXPECT_GT(truth.edges, near.edges) << "bright " << bright;
    EXPECT_GT(near.edges, far.edges) << "bright " << bright;
  }
}
