#include "fluoro_tracker/registration/tracker.h"

#include <cmath>
#include <limits>
#include <random>

#include "../test_support.h"
#include "fluoro_tracker/registration/pose_error.h"
#include "fluoro_tracker/sim/trial_simulator.h"

using namespace fluoro_tracker;
using geometry::Pose;

namespace {

struct Trial {
  sim::TrialSimulator simulator{settings()};
  std::shared_ptr<const registration::Registrar> registrar;

  Trial() {
    std::vector<registration::BoneModel> bones = {
        {"femur",
         std::make_shared<imaging::SilhouetteModel>(simulator.implants().femoral_component), 1.0},
        {"tibia", std::make_shared<imaging::SilhouetteModel>(simulator.implants().tibial_tray),
         1.0}};
    registrar =
        std::make_shared<registration::Registrar>(bones, registration::RegistrationSettings());
  }
  static sim::TrialSimulatorSettings settings() {
    sim::TrialSimulatorSettings s;
    s.motion.frames = 30;
    return s;
  }
  std::vector<registration::ViewImage> views(const sim::SimulatedFrame& frame) const {
    return {{frame.images[0], simulator.views()[0].camera}};
  }
};

}  // namespace

TEST(Tracker, FollowsATrialFromItsFirstPose) {
  const Trial trial;
  const auto first = trial.simulator.truth(0);
  registration::Tracker tracker(trial.registrar, {first.femur, first.tibia});
  std::mt19937_64 rng(2);
  const Pose camera_from_fixed = trial.simulator.views()[0].camera.worldFromCamera().inverse();
  for (int f = 1; f < 6; ++f) {
    const auto frame = trial.simulator.render(f, &rng);
    const registration::TrackedFrame tracked = tracker.track(trial.views(frame));
    const std::vector<Pose> truth = {frame.femur, frame.tibia};
    for (int b = 0; b < 2; ++b) {
      EXPECT_EQ(tracked.status[b], "ok");
      EXPECT_TRUE(registration::meetsSuccessCriterion(
          registration::poseError(tracked.poses[b], truth[b], camera_from_fixed)))
          << "frame " << f << " bone " << b;
    }
    EXPECT_GT(tracked.solve_seconds, 0.0);
    EXPECT_TRUE(tracked.poses[0].isApprox(tracker.poses()[0]));
  }
}

TEST(Tracker, BadInputLeavesTheStateAlone) {
  const Trial trial;
  const auto first = trial.simulator.truth(0);
  registration::Tracker tracker(trial.registrar, {first.femur, first.tibia});
  const std::vector<Pose> before = tracker.poses();
  EXPECT_THROW_WITH(tracker.track({{cv::Mat(), trial.simulator.views()[0].camera}}), "empty");
  EXPECT_THROW_WITH(tracker.reinitialize({"patella"}, {first.femur}), "no bone named 'patella'");
  Pose broken = first.femur;
  broken.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW_WITH(tracker.reinitialize({"tibia", "femur"}, {first.tibia, broken}),
                    "not a finite rigid transform");
  EXPECT_THROW_WITH(tracker.reinitialize({"tibia"}, {}), "1 bone name(s) but 0 pose(s)");
  for (int b = 0; b < 2; ++b) EXPECT_TRUE(tracker.poses()[b].isApprox(before[b]));
  // A good re-initialisation moves only the bones named.
  const auto later = trial.simulator.truth(10);
  tracker.reinitialize({"tibia"}, {later.tibia});
  EXPECT_TRUE(tracker.poses()[0].isApprox(before[0]));
  EXPECT_TRUE(tracker.poses()[1].isApprox(later.tibia, 1e-9));
  EXPECT_THROW_WITH(registration::Tracker(trial.registrar, {first.femur}), "1 initial pose(s)");
}
