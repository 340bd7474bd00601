#include "fluoro_tracker/registration/pose_search.h"

#include <random>

#include <gtest/gtest.h>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/registration/pose_error.h"
#include "fluoro_tracker/sim/trial_simulator.h"
#include "simulated_knee.h"

using namespace fluoro_tracker;
using geometry::Pose;

using test_support::simulatedKneeRegistrar;

TEST(SilhouetteLibrary, RecoversTheOrientationOfARenderedView) {
  sim::TrialSimulatorSettings s;
  s.motion.frames = 10;
  const sim::TrialSimulator sim(s);
  std::mt19937_64 rng(3);
  const auto frame = sim.render(0, &rng);
  const geometry::XrayCamera& camera = sim.views()[0].camera;
  const Pose truth = camera.worldFromCamera().inverse() * frame.tibia;
  const imaging::SilhouetteLibrary library(sim.implants().tibial_tray);
  double best_angle = 180.0;
  for (const auto& blob : imaging::findImplantBlobs(frame.images[0])) {
    for (const auto& match : library.match(blob, 4)) {
      const Pose pose = library.cameraFromMesh(match, blob, camera);
      if ((pose.translation() - truth.translation()).norm() > 0.15) continue;
      best_angle = std::min(best_angle, geometry::radToDeg(geometry::rotationAngleBetween(
                                            pose.linear(), truth.linear())));
    }
  }
  // Within a library step (15 deg) of the truth, before any registration.
  EXPECT_LT(best_angle, 15.0);
}

TEST(PoseSearch, FindsBothComponentsWithNoGuess) {
  sim::TrialSimulatorSettings s;
  s.motion.frames = 10;
  for (bool bright : {false, true}) {
    s.detector.implants_bright = bright;
    const sim::TrialSimulator sim(s);
    std::mt19937_64 rng(5);
    const auto frame = sim.render(0, &rng);
    const registration::PoseSearch search(simulatedKneeRegistrar(sim));
    const auto found = search.search({{frame.images[0], sim.views()[0].camera}});
    const Pose camera_from_fixed = sim.views()[0].camera.worldFromCamera().inverse();
    const std::vector<Pose> truth = {frame.femur, frame.tibia};
    for (int b = 0; b < 2; ++b) {
      const auto e =
          registration::poseError(found.registration.poses[b], truth[b], camera_from_fixed);
      EXPECT_TRUE(registration::meetsSuccessCriterion(e))
          << (bright ? "bright" : "dark") << " implants, bone " << b << ": in-plane "
          << e.translation_mm.head<2>().transpose() << " mm, rotation "
          << e.rotation_deg.transpose() << " deg";
      EXPECT_EQ(found.status[b], "ok");
    }
    EXPECT_GT(found.regions, 0);
  }
}

TEST(PoseSearch, ABlankFrameIsReportedNotGuessed) {
  sim::TrialSimulatorSettings s;
  s.motion.frames = 10;
  const sim::TrialSimulator sim(s);
  const registration::PoseSearch search(simulatedKneeRegistrar(sim));
  const cv::Mat blank(sim.views()[0].camera.height(), sim.views()[0].camera.width(), CV_16U,
                      cv::Scalar(1000));
  EXPECT_THROW(search.search({{blank, sim.views()[0].camera}}), InputError);
  registration::PoseSearchSettings bad;
  bad.min_depth_m = 3.0;
  bad.max_depth_m = 1.0;
  EXPECT_THROW(registration::PoseSearch(simulatedKneeRegistrar(sim), bad), InputError);
}
