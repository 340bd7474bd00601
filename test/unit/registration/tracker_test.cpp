#include "fluoro_tracker/registration/tracker.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "../test_support.h"
#include "fluoro_tracker/registration/frame_quality.h"
#include "fluoro_tracker/registration/mirror_ambiguity.h"
#include "fluoro_tracker/registration/pose_error.h"
#include "fluoro_tracker/sim/trial_simulator.h"
#include "simulated_knee.h"

using namespace fluoro_tracker;
using geometry::Pose;

namespace {

struct Trial {
  sim::TrialSimulator simulator{settings()};
  std::shared_ptr<const registration::Registrar> registrar;

  Trial() {
    registrar = std::make_shared<registration::Registrar>(
        test_support::simulatedKneeBones(simulator), registration::RegistrationSettings());
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

// A simulated trial and its frames 0 to `last` as simulate_trial writes them (the noise drawn in
// frame order from the trial's seed): a robustness variant (config/robustness/<name>.yaml), or
// a benchmark trial (benchmarkTrial).
struct VariantFrames {
  sim::TrialSimulator simulator;
  std::vector<sim::SimulatedFrame> frames;

  VariantFrames(const std::string& name, int last)
      : VariantFrames(sim::loadSimulatorSettings(std::string(FLUORO_SOURCE_DIR) +
                                                 "/config/robustness/" + name + ".yaml"),
                      last) {}
  VariantFrames(const sim::TrialSimulatorSettings& settings, int last) : simulator(settings) {
    std::mt19937_64 rng(simulator.settings().seed);
    for (int f = 0; f <= last; ++f) frames.push_back(simulator.render(f, &rng));
  }
  // Trial `trial` of 60 frames as `benchmark` and `recovery_benchmark --seed seed` vary it
  // (sim::varyBenchmarkTrial, drawn in trial order; noise seed seed + trial).
  static sim::TrialSimulatorSettings benchmarkTrial(int seed, int trial) {
    sim::TrialSimulatorSettings s;
    s.motion.frames = 60;
    std::mt19937_64 vary(static_cast<std::uint64_t>(seed));
    for (int t = 0; t <= trial; ++t) sim::varyBenchmarkTrial(t, &vary, &s);
    s.seed = static_cast<std::uint64_t>(seed + trial);
    return s;
  }
  const geometry::XrayCamera& camera() const { return simulator.views()[0].camera; }
  Pose cameraFromFixed() const { return camera().worldFromCamera().inverse(); }

  // Each frame's pose errors (femur, tibia), tracked from frame 0's true poses with `settings`.
  std::vector<std::array<registration::PoseError, 2>> trackedErrors(
      const registration::RegistrationSettings& settings) const {
    registration::Tracker tracker(test_support::simulatedKneeRegistrar(simulator, settings),
                                  {frames[0].femur, frames[0].tibia});
    std::vector<std::array<registration::PoseError, 2>> errors;
    for (const sim::SimulatedFrame& frame : frames) {
      const registration::TrackedFrame tracked = tracker.track({{frame.images[0], camera()}});
      errors.push_back({registration::poseError(tracked.poses[0], frame.femur, cameraFromFixed()),
                        registration::poseError(tracked.poses[1], frame.tibia, cameraFromFixed())});
    }
    return errors;
  }

  // Of those frames after frame 0, how many have a bone outside the success criteria.
  static int framesOffAfterTheFirst(
      const std::vector<std::array<registration::PoseError, 2>>& errors) {
    int off = 0;
    for (std::size_t f = 1; f < errors.size(); ++f) {
      if (!registration::meetsSuccessCriterion(errors[f][0]) ||
          !registration::meetsSuccessCriterion(errors[f][1])) {
        ++off;
      }
    }
    return off;
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

// A bone that loses a fifth of its edges (here: the femur's far side covered by a uniform
// patch, as by a lead marker or the collimator) still has more inliers than the absolute
// threshold asks, but far fewer than in its own earlier frames: the tracker calls it suspect
// (InlierHistory), while the untouched tibia stays ok.
TEST(Tracker, CallsABoneSuspectWhoseInliersDropBelowItsOwnEarlierFrames) {
  const Trial trial;
  const auto first = trial.simulator.truth(0);
  registration::Tracker tracker(trial.registrar, {first.femur, first.tibia});
  std::mt19937_64 rng(6);
  for (int f = 1; f < 5; ++f) {
    const auto frame = trial.simulator.render(f, &rng);
    ASSERT_EQ(tracker.track(trial.views(frame)).status, (std::vector<std::string>{"ok", "ok"}));
  }
  auto covered = trial.simulator.render(5, &rng);
  const auto& camera = trial.simulator.views()[0].camera;
  const Pose camera_from_fixed = camera.worldFromCamera().inverse();
  const auto femur =
      trial.registrar->bones()[0].silhouette->contour(camera, camera_from_fixed * covered.femur);
  const auto tibia =
      trial.registrar->bones()[1].silhouette->contour(camera, camera_from_fixed * covered.tibia);
  ASSERT_FALSE(femur.empty());
  ASSERT_FALSE(tibia.empty());
  Eigen::Vector2d femur_centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d tibia_centre = Eigen::Vector2d::Zero();
  for (const auto& c : femur) femur_centre += c.pixel / static_cast<double>(femur.size());
  for (const auto& c : tibia) tibia_centre += c.pixel / static_cast<double>(tibia.size());
  // The fifth of the femur's contour farthest from the tibia.
  const Eigen::Vector2d away = (femur_centre - tibia_centre).normalized();
  std::vector<double> reach;
  for (const auto& c : femur) reach.push_back((c.pixel - femur_centre).dot(away));
  std::vector<double> sorted = reach;
  std::sort(sorted.begin(), sorted.end());
  const double cut = sorted[sorted.size() * 4 / 5];
  std::vector<cv::Point> far;
  for (std::size_t k = 0; k < femur.size(); ++k) {
    if (reach[k] >= cut) far.emplace_back(cvRound(femur[k].pixel.x()), cvRound(femur[k].pixel.y()));
  }
  cv::Mat& image = covered.images[0];
  const cv::Rect patch = (cv::boundingRect(far) + cv::Size(16, 16)) - cv::Point(8, 8);
  const cv::Rect inside = patch & cv::Rect(0, 0, image.cols, image.rows);
  image(inside).setTo(cv::mean(image(inside)));

  const registration::TrackedFrame tracked = tracker.track(trial.views(covered));
  const std::vector<std::string> absolute =
      registration::classifyBones(tracked.result, trial.registrar->settings().quality);
  // Otherwise the frame shows nothing: the absolute thresholds alone must pass the femur.
  ASSERT_EQ(absolute[0], "ok") << "diverged " << tracked.result.diverged[0] << ", inlier fraction "
                               << tracked.result.quality[0].contour_inlier_fraction;
  EXPECT_EQ(tracked.status, (std::vector<std::string>{"suspect", "ok"}))
      << "femur inlier fraction " << tracked.result.quality[0].contour_inlier_fraction;
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

TEST(Tracker, StartsWithoutPosesAndRecoversAfterABlankFrame) {
  const Trial trial;
  const auto registrar = test_support::simulatedKneeRegistrar(trial.simulator);
  const auto search = std::make_shared<registration::PoseSearch>(registrar);
  registration::Tracker tracker(registrar, {}, search);
  EXPECT_FALSE(tracker.initialized());
  std::mt19937_64 rng(4);
  const Pose camera_from_fixed = trial.simulator.views()[0].camera.worldFromCamera().inverse();
  const auto accurate = [&](const registration::TrackedFrame& tracked,
                            const sim::SimulatedFrame& frame) {
    const std::vector<Pose> truth = {frame.femur, frame.tibia};
    for (int b = 0; b < 2; ++b) {
      if (!registration::meetsSuccessCriterion(
              registration::poseError(tracked.poses[b], truth[b], camera_from_fixed)))
        return false;
    }
    return true;
  };
  // Frame 0: nearly extended, the components' silhouettes apart; no guess at all. Pixel noise
  // before it is no first frame: nothing to search, and nothing changes.
  const auto frame0 = trial.simulator.render(0, &rng);
  auto noise = frame0;
  noise.images[0] = frame0.images[0].clone();
  const int levels = noise.images[0].depth() == CV_16U ? 65536 : 256;
  cv::RNG(9).fill(noise.images[0], cv::RNG::UNIFORM, 0, levels);
  EXPECT_THROW_WITH(tracker.track(trial.views(noise)),
                    "pose search: the frame shows pixel noise only");
  EXPECT_FALSE(tracker.initialized());
  const registration::TrackedFrame found = tracker.track(trial.views(frame0));
  EXPECT_TRUE(found.searched);
  EXPECT_TRUE(tracker.initialized());
  EXPECT_TRUE(accurate(found, frame0));
  EXPECT_EQ(found.status, (std::vector<std::string>{"ok", "ok"}));

  const auto frame1 = trial.simulator.render(1, &rng);
  EXPECT_TRUE(accurate(tracker.track(trial.views(frame1)), frame1));
  const std::vector<Pose> good = tracker.poses();

  // A blank frame (the beam off) and one of pixel noise (a read-out fault): every bone lost,
  // their last good poses kept, no jump, and the frames given up without a search, the tracker
  // left as it was. With the test off the blank frame is retried and searched in vain, and the
  // tracker recovers on the next frame.
  for (const bool test : {false, true}) {
    registration::RegistrationSettings settings;
    settings.featureless_noise_ratio = test ? 0.5 : 0.0;
    const auto tested = test_support::simulatedKneeRegistrar(trial.simulator, settings);
    registration::Tracker blank_tracker(tested, good,
                                        std::make_shared<registration::PoseSearch>(tested));
    auto blank = trial.simulator.render(2, &rng);
    blank.images[0].setTo(cv::Scalar(1000));
    const registration::TrackedFrame lost = blank_tracker.track(trial.views(blank));
    EXPECT_EQ(lost.status, (std::vector<std::string>{"lost", "lost"}));
    EXPECT_TRUE(lost.poses[0].isApprox(good[0]));
    EXPECT_TRUE(lost.poses[1].isApprox(good[1]));
    EXPECT_EQ(lost.searched, !test);
    EXPECT_EQ(blank_tracker.recovering(), !test);
    if (test) {
      EXPECT_EQ(lost.given_up, "the frame shows one grey level");
      cv::RNG(11).fill(blank.images[0], cv::RNG::UNIFORM, 0, levels);
      const registration::TrackedFrame noisy = blank_tracker.track(trial.views(blank));
      EXPECT_EQ(noisy.status, (std::vector<std::string>{"lost", "lost"}));
      EXPECT_NE(noisy.given_up.find("the frame shows pixel noise only"), std::string::npos)
          << noisy.given_up;
      EXPECT_FALSE(noisy.searched);
      EXPECT_TRUE(noisy.poses[1].isApprox(good[1]));
    } else {
      EXPECT_EQ(lost.given_up, "");
    }
    // Back on the next frame: registered from the last good poses, by the recovery that the
    // search in vain began (RegistrationSettings::tracking_recovery_registration), or tracked on.
    const auto frame = trial.simulator.render(3, &rng);
    const registration::TrackedFrame tracked = blank_tracker.track(trial.views(frame));
    EXPECT_FALSE(tracked.searched);
    EXPECT_TRUE(accurate(tracked, frame)) << test;
    EXPECT_FALSE(blank_tracker.recovering());
  }
}

// The benchmark's trial 0 at seed 7 (sim::varyBenchmarkTrial): its tray's plateau passes edge-on
// near frame 19, where the varus-valgus tilt has no sign. Continued frames that tried only the
// turn reflection there took the tilt's mirror branch and stayed on it, 2.2-4.4 deg off with
// every status ok, until frame 29; trying the tilt reflection too keeps the truth's branch.
TEST(Tracker, TriesTheTiltReflectionWhereTheTraysPlateauPassesEdgeOn) {
  const VariantFrames trial(VariantFrames::benchmarkTrial(7, 0), 24);
  for (const bool tilt : {false, true}) {
    SCOPED_TRACE(tilt);
    registration::RegistrationSettings settings;
    settings.mirror_check.tracking_tilt_reflection = tilt;
    int tilted_off = 0;
    for (const auto& errors : trial.trackedErrors(settings)) {
      if (std::abs(errors[1].rotation_deg.x()) > 2.0) ++tilted_off;
    }
    if (tilt) {
      EXPECT_EQ(tilted_off, 0);
    } else {
      EXPECT_GE(tilted_off, 3) << "the trial no longer shows the tilt branch this test is for";
    }
  }
}

// The benchmark's trial 3 at seed 5 (sim::varyBenchmarkTrial), back toward extension: the
// tray slides frame by frame into a false minimum, its tilt 3 deg off by frame 54 with every
// status ok, while its contour's spread about the edges rises from about 0.29 px to 0.47 px.
// A tracked frame's rotation retry (RotationRetrySettings::tracking_spread_rise) frees it there;
// without it the tray stays off to the trial's end.
TEST(Tracker, RetriesTheRotationsOfATrayWhoseSpreadRoseAboveItsRecentFrames) {
  const VariantFrames trial(VariantFrames::benchmarkTrial(5, 3), 58);
  for (const double rise : {0.0, registration::RotationRetrySettings().tracking_spread_rise}) {
    SCOPED_TRACE(rise);
    registration::RegistrationSettings settings;
    settings.rotation_retry.tracking_spread_rise = rise;
    const auto errors = trial.trackedErrors(settings);
    int off_at_the_end = 0;  // frames 55-58
    for (std::size_t f = 55; f < errors.size(); ++f) {
      if (!registration::meetsSuccessCriterion(errors[f][1])) ++off_at_the_end;
    }
    if (rise > 0.0) {
      EXPECT_EQ(off_at_the_end, 0);
    } else {
      EXPECT_GE(off_at_the_end, 3) << "the trial no longer shows the slide this test is for";
    }
  }
}

// A frame that shows a knee, but not where this one was a moment ago (here the frame flipped left
// to right, as a misconfigured grabber or a wrong file would give): the tracker's own
// registration loses it, and the search that follows finds the mirrored knee, a fit as good as
// any. Asked for (requestSearch), that is the answer; while recovering, a bone found farther from
// its last good pose than it can move in a frame is kept lost there, and the next frame is back.
TEST(Tracker, DoesNotFollowASearchToAKneeWhereTheBoneCannotBe) {
  const Trial trial;
  const auto registrar = test_support::simulatedKneeRegistrar(trial.simulator);
  const auto search = std::make_shared<registration::PoseSearch>(registrar);
  std::mt19937_64 rng(6);
  const Pose camera_from_fixed = trial.simulator.views()[0].camera.worldFromCamera().inverse();
  const auto within = [&](const Pose& pose, const Pose& truth) {
    return registration::meetsSuccessCriterion(
        registration::poseError(pose, truth, camera_from_fixed));
  };
  // Frame 8 (about 50 deg of flexion): flipped, its tray and femoral component both leave the
  // prediction's reach, so the tracker searches it. (Nearer extension the tray's flipped outline
  // lies within reach and fits at status ok beside a suspect femur: the frame is flagged, the
  // tray's pose is wrong; see README "Recovery".)
  constexpr int kFlipped = 8;
  std::vector<sim::SimulatedFrame> frames;
  for (int f = 0; f <= kFlipped + 1; ++f) frames.push_back(trial.simulator.render(f, &rng));
  sim::SimulatedFrame mirrored = frames[kFlipped];
  cv::flip(frames[kFlipped].images[0], mirrored.images[0], 1);

  // The trap: searched on request, the mirrored frame gives a knee at status ok, far off.
  registration::Tracker asked(registrar, {frames[0].femur, frames[0].tibia}, search);
  asked.track(trial.views(frames[0]));
  asked.requestSearch();
  const registration::TrackedFrame taken = asked.track(trial.views(mirrored));
  ASSERT_TRUE(taken.searched);
  ASSERT_EQ(taken.status, (std::vector<std::string>{"ok", "ok"}));
  ASSERT_FALSE(within(taken.poses[0], frames[kFlipped].femur));
  EXPECT_TRUE(taken.implausible_jump.empty());

  registration::Tracker tracker(registrar, {frames[0].femur, frames[0].tibia}, search);
  for (int f = 0; f < kFlipped; ++f) {
    ASSERT_EQ(tracker.track(trial.views(frames[static_cast<std::size_t>(f)])).status,
              (std::vector<std::string>{"ok", "ok"}))
        << "frame " << f;
  }
  const std::vector<Pose> good = tracker.poses();
  const registration::TrackedFrame kept = tracker.track(trial.views(mirrored));
  ASSERT_TRUE(kept.searched);
  ASSERT_EQ(kept.implausible_jump.size(), 2u);
  EXPECT_TRUE(kept.implausible_jump[0]);
  EXPECT_EQ(kept.status[0], "lost");
  const std::vector<Pose> truth = {frames[kFlipped].femur, frames[kFlipped].tibia};
  for (std::size_t b = 0; b < 2; ++b) {
    // Lost at its last good pose, or (a bone found where it can be) within the criterion.
    if (kept.status[b] == "lost") {
      EXPECT_TRUE(kept.poses[b].isApprox(good[b])) << "bone " << b;
    } else {
      EXPECT_TRUE(within(kept.poses[b], truth[b])) << "bone " << b;
    }
  }
  EXPECT_TRUE(tracker.recovering());
  // A blank frame meanwhile is given up at once, neither registered nor searched, and the
  // tracker is still recovering.
  sim::SimulatedFrame blank = frames[kFlipped];
  blank.images[0] =
      cv::Mat(frames[kFlipped].images[0].size(), frames[kFlipped].images[0].type(), cv::Scalar(40));
  const registration::TrackedFrame given_up = tracker.track(trial.views(blank));
  EXPECT_EQ(given_up.given_up, "the frame shows one grey level");
  EXPECT_FALSE(given_up.searched);
  EXPECT_TRUE(tracker.recovering());
  // Back on the next frame, registered from the last good poses, which leaves both bones ok: no
  // search (RegistrationSettings::tracking_recovery_registration).
  const registration::TrackedFrame back = tracker.track(trial.views(frames[kFlipped + 1]));
  EXPECT_FALSE(back.searched);
  EXPECT_EQ(back.status, (std::vector<std::string>{"ok", "ok"}));
  EXPECT_TRUE(within(back.poses[0], frames[kFlipped + 1].femur));
  EXPECT_TRUE(within(back.poses[1], frames[kFlipped + 1].tibia));
  EXPECT_FALSE(tracker.recovering());
}

// Near extension a flipped frame's tray outline lies within the prediction's reach: the tray
// fits it turned 10 deg at status ok beside a suspect femur (the frame is flagged, not lost, so
// nothing is searched). The next frame, registered on from that turned tray, ended 3.2 deg off
// about the stem at status ok; registered on from the frames before the flipped one as well
// (RegistrationSettings::tracking_restart_after_suspect), it is back at once.
TEST(Tracker, RestartsFromTheLastGoodPosesAfterAFreshlySuspectFrame) {
  const Trial trial;
  std::mt19937_64 rng(6);
  constexpr int kFlipped = 2;
  constexpr int kAfter = 3;  // frames tracked after the flipped one
  std::vector<sim::SimulatedFrame> frames;
  for (int f = 0; f <= kFlipped + kAfter; ++f) frames.push_back(trial.simulator.render(f, &rng));
  cv::flip(frames[kFlipped].images[0], frames[kFlipped].images[0], 1);
  const Pose camera_from_fixed = trial.simulator.views()[0].camera.worldFromCamera().inverse();
  for (const bool restart : {false, true}) {
    SCOPED_TRACE(restart);
    registration::RegistrationSettings settings;
    settings.tracking_restart_after_suspect = restart;
    registration::Tracker tracker(test_support::simulatedKneeRegistrar(trial.simulator, settings),
                                  {frames[0].femur, frames[0].tibia});
    int off_after = 0;  // frames after the flipped one with a bone off the criterion
    for (int f = 0; f <= kFlipped + kAfter; ++f) {
      const sim::SimulatedFrame& frame = frames[static_cast<std::size_t>(f)];
      const registration::TrackedFrame tracked = tracker.track(trial.views(frame));
      if (f == kFlipped) {
        ASSERT_NE(tracked.status, (std::vector<std::string>{"ok", "ok"}));
        ASSERT_EQ(std::count(tracked.status.begin(), tracked.status.end(), "lost"), 0)
            << "the flipped frame is lost here, not suspect: not the case this test is for";
      } else if (f > kFlipped) {
        const bool within = registration::meetsSuccessCriterion(registration::poseError(
                                tracked.poses[0], frame.femur, camera_from_fixed)) &&
                            registration::meetsSuccessCriterion(registration::poseError(
                                tracked.poses[1], frame.tibia, camera_from_fixed));
        off_after += within ? 0 : 1;
      }
    }
    if (restart) {
      EXPECT_EQ(off_after, 0);
    } else {
      EXPECT_GE(off_after, 1) << "the trial no longer shows the carried turn this test is for";
    }
  }
}

// A crude first-frame guess (the chapter 4 scale: centimetres along the beam, millimetres and
// degrees across it) that registration alone loses is searched on that same frame, so the
// first frame is not given up.
TEST(Tracker, SearchesALostFrameAtOnce) {
  const Trial trial;
  const auto registrar = test_support::simulatedKneeRegistrar(trial.simulator);
  const auto search = std::make_shared<registration::PoseSearch>(registrar);
  std::mt19937_64 rng(5);
  const auto frame0 = trial.simulator.render(0, &rng);
  const Pose camera_from_fixed = trial.simulator.views()[0].camera.worldFromCamera().inverse();
  const Eigen::Matrix3d to_fixed = camera_from_fixed.linear().transpose();
  Pose femur = frame0.femur;
  femur.translation() += to_fixed * Eigen::Vector3d(0.003, -0.003, 0.020);
  Pose tibia = frame0.tibia;
  tibia.translation() += to_fixed * Eigen::Vector3d(-0.003, 0.003, -0.045);
  tibia.linear() = tibia.linear() * geometry::rotationY(geometry::degToRad(10.0));
  const std::vector<Pose> crude = {femur, tibia};

  registration::Tracker without_search(registrar, crude);
  const registration::TrackedFrame given_up = without_search.track(trial.views(frame0));
  ASSERT_NE(given_up.status, (std::vector<std::string>{"ok", "ok"}))
      << "the crude guess must defeat registration alone for this test";

  registration::Tracker tracker(registrar, crude, search);
  const registration::TrackedFrame tracked = tracker.track(trial.views(frame0));
  EXPECT_TRUE(tracked.searched);
  EXPECT_EQ(tracked.status, (std::vector<std::string>{"ok", "ok"}));
  const std::vector<Pose> truth = {frame0.femur, frame0.tibia};
  for (int b = 0; b < 2; ++b) {
    EXPECT_TRUE(registration::meetsSuccessCriterion(
        registration::poseError(tracked.poses[b], truth[b], camera_from_fixed)))
        << "bone " << b;
  }
  EXPECT_FALSE(tracker.recovering());
}

// Poses the user gives may sit on the tray's mirror branch: the first frame is mirror-checked
// (and lands on the truth); frames started from an earlier registration are not (one solve,
// at most the configured outer iterations).
// Every mirror is checked from poses the user gave (the first frame); frames continued from an
// earlier result check only the turn reflection, when within tracking_turn_max_difference_deg.
TEST(Tracker, ChecksTheMirrorFromPosesTheUserGaveAndNearMirrorsWhileTracking) {
  sim::TrialSimulatorSettings s;
  s.motion.frames = 12;
  const sim::TrialSimulator simulator(s);
  // The knee with its ligament envelope and no contact: from the mirrored start the tray's
  // plate cuts deep into the femoral component, and contact would push the bones apart first.
  registration::JointModel knee;
  knee.name = "knee";
  knee.parent = 0;
  knee.child = 1;
  const auto makeRegistrar = [&](double tracking_turn_max_difference_deg) {
    registration::RegistrationSettings settings;
    settings.mirror_check.tracking_turn_max_difference_deg = tracking_turn_max_difference_deg;
    return std::make_shared<const registration::Registrar>(
        test_support::simulatedKneeBones(simulator), settings,
        std::vector<registration::JointModel>{knee});
  };
  std::mt19937_64 rng(3);
  const auto frame = simulator.render(5, &rng);
  const geometry::XrayCamera& camera = simulator.views()[0].camera;
  const Pose camera_from_fixed = camera.worldFromCamera().inverse();
  const Pose mirrored_tibia =
      camera.worldFromCamera() * registration::mirroredAcrossBeam(camera_from_fixed * frame.tibia);
  ASSERT_GT(geometry::radToDeg(
                geometry::rotationAngleBetween(mirrored_tibia.linear(), frame.tibia.linear())),
            2.0);
  const Pose turned_tibia = registration::turnReflectedAcrossBeam(camera_from_fixed * frame.tibia);
  ASSERT_GT(geometry::radToDeg(geometry::rotationAngleBetween(
                turned_tibia.linear(), (camera_from_fixed * frame.tibia).linear())),
            2.0);
  const std::vector<registration::ViewImage> views = {{frame.images[0], camera}};
  // Outer iterations of one solve over these scales.
  const registration::RegistrationSettings defaults;
  const int coarse = defaults.coarse_outer_iterations > 0 ? defaults.coarse_outer_iterations
                                                          : defaults.outer_iterations;
  const auto one_solve = [&](const std::vector<double>& scales) {
    return defaults.outer_iterations + coarse * static_cast<int>(scales.size() - 1);
  };
  for (const double tracking_turn_max_difference_deg : {0.0, 180.0}) {
    SCOPED_TRACE(tracking_turn_max_difference_deg);
    registration::Tracker tracker(makeRegistrar(tracking_turn_max_difference_deg),
                                  {frame.femur, mirrored_tibia});
    const registration::TrackedFrame first = tracker.track(views);
    EXPECT_TRUE(registration::meetsSuccessCriterion(
        registration::poseError(first.poses[1], frame.tibia, camera_from_fixed)));
    EXPECT_GT(first.result.outer_iterations, one_solve(defaults.scales));  // the check's solves
    // Continued from the first frame: the tracking scales only, and the turn reflection's solve
    // only when it may be tried at any distance (this tray's is farther than 2 deg).
    const registration::TrackedFrame second = tracker.track(views);
    if (tracking_turn_max_difference_deg == 0.0) {
      EXPECT_LE(second.result.outer_iterations, one_solve(defaults.tracking_scales));
    } else {
      EXPECT_GT(second.result.outer_iterations, one_solve(defaults.tracking_scales));
    }
    EXPECT_TRUE(registration::meetsSuccessCriterion(
        registration::poseError(second.poses[1], frame.tibia, camera_from_fixed)));
  }
}

// A continued registration starts from the last frame's result and carried edge offset, and a
// bone's offset and its depth change its outline almost alike, so the two can slide together a
// little in every frame. In the robustness variant of bright titanium at half the dose, seen
// obliquely with beads and a platform, the knee drifted 25-34 mm along the beam over frames
// 15-25, every status ok (the inlier history's trend line follows so slow a decline). A bone
// fitting clearly worse than its recent frames now has the frame registered again with the full
// schedule (RegistrationSettings::tracking_retry_inlier_drop), which keeps the knee near the
// truth.
TEST(Tracker, RetriesAFrameWhoseBoneFitsWorseThanItsRecentFrames) {
  const VariantFrames variant("titanium_clutter_oblique", 25);
  struct Run {
    double farthest_mm = 0.0;  // along the beam, either bone, any frame
    int successes = 0;
  };
  const auto track = [&](double inlier_drop) {
    registration::RegistrationSettings settings;
    settings.tracking_retry_inlier_drop = inlier_drop;
    // The statuses under which the drift was found (stop 48): the contour RMS test, not the
    // spread test (stop 53), which by making some of these frames suspect retries them too and
    // halves the drift without this rule (9 mm), so that the rule's own effect would not show.
    settings.quality.suspect_contour_rms_px = 1.0;
    settings.quality.suspect_contour_spread_px = 0.0;
    // The tracked frames' rotation retry (stop 62) frees the drifting knee too (7 mm at most
    // without this rule); off, so that this rule's own effect shows.
    settings.rotation_retry.tracking_spread_rise = 0.0;
    Run run;
    for (const auto& errors : variant.trackedErrors(settings)) {
      bool success = true;
      for (const registration::PoseError& error : errors) {
        run.farthest_mm = std::max(run.farthest_mm, std::abs(error.translation_mm.z()));
        success = success && registration::meetsSuccessCriterion(error);
      }
      run.successes += success ? 1 : 0;
    }
    return run;
  };
  const Run without = track(0.0);
  ASSERT_GT(without.farthest_mm, 15.0)
      << "the knee must drift without the retry for the test to mean anything";
  ASSERT_LT(without.successes, static_cast<int>(variant.frames.size()) - 5);
  const Run with = track(registration::RegistrationSettings().tracking_retry_inlier_drop);
  EXPECT_LT(with.farthest_mm, 10.0);
  // Frame 15 tilts the tray 2.2 deg about its X axis (the criterion: 2) before either bone fits
  // 0.08 worse than its recent frames: no retry yet.
  EXPECT_GE(with.successes, static_cast<int>(variant.frames.size()) - 1);
}

// The Kneel study's tray in titanium (config/robustness/kneel_titanium_tray.yaml): its plate's
// rim and pocket show as edges a few pixels inside its outline while its true top edge hardly
// shows, and tracked as it is the tray is drawn to them, about 3.3 deg off in the image plane.
// Leaving out each bone's edges more than 2 px inside its own silhouette once its contour is
// close (inner_edge_margin_px) keeps the tracked tray within the criteria.
TEST(Tracker, InnerEdgeMarginKeepsATitaniumTrayOffItsOwnInnerEdges) {
  const VariantFrames variant("kneel_titanium_tray", 20);
  // The margin as tracked frames have it by default (tracking_inner_edge_margin_px), or none.
  const auto successes = [&](bool default_margin) {
    registration::RegistrationSettings settings;
    EXPECT_EQ(settings.inner_edge_margin_px, 0.0);
    if (!default_margin) settings.tracking_inner_edge_margin_px = 0.0;
    int count = 0;
    for (const auto& errors : variant.trackedErrors(settings)) {
      count += registration::meetsSuccessCriterion(errors[1]) ? 1 : 0;
    }
    return count;
  };
  const int as_is = successes(false);
  ASSERT_LT(as_is, static_cast<int>(variant.frames.size()) - 5)
      << "the tray must be drawn to its inner edges for the test to mean anything";
  EXPECT_GE(successes(true), static_cast<int>(variant.frames.size()) - 1);
}

// The same titanium tray with the contour RMS test on at 0.9 px (stop 52's default was 1.0; off
// since stop 53, see QualitySettings::suspect_contour_spread_px). From frame 19 on, a continued
// registration with the tray's RMS just over it leaves the frame in more doubt than the one before,
// and the full schedule's retry lands on the tray's tilt reflection: status ok at a lower RMS, but
// fitting less of the outline. Kept, the tray tracks on 2.7-3.5 deg off about its anterior axis
// (frames 19-24 all fail). Tracked from no guess, the same happened at stop 52's default threshold
// on this variant's seed 4 (the retry 0.67 of the tray's outline on edges against the continued
// 0.75). A retry that clears the doubt must fit about as much of every outline
// (RegistrationSettings::tracking_retry_max_inlier_loss).
TEST(Tracker, RetryThatClearsDoubtMustFitAboutAsMuchOfTheOutline) {
  const VariantFrames variant("kneel_titanium_tray", 24);
  const auto failures = [&](double max_inlier_loss) {
    registration::RegistrationSettings settings;
    settings.quality.suspect_contour_rms_px = 0.9;
    // ... and the inlier tests counting the outline where it lies (stop 55 counts each sample
    // at the edge offset, QualitySettings::inliers_at_edge_offset), the statuses it was found
    // under.
    settings.quality.inliers_at_edge_offset = false;
    settings.tracking_retry_max_inlier_loss = max_inlier_loss;
    // The tracked frames' rotation retry (stop 62) frees the tray from its tilt reflection too
    // (no frame fails without this guard); off, so that the guard's own effect shows.
    settings.rotation_retry.tracking_spread_rise = 0.0;
    // So does the frame after the first in doubt, registered on from the frames before it as
    // well (stop 67, tracking_restart_after_suspect: 1 frame fails unguarded).
    settings.tracking_restart_after_suspect = false;
    int count = 0;
    for (const auto& errors : variant.trackedErrors(settings)) {
      count += registration::meetsSuccessCriterion(errors[1]) ? 0 : 1;
    }
    return count;
  };
  const int unguarded = failures(1.0);
  ASSERT_GE(unguarded, 4) << "the retry must take the tray's tilt reflection for the test to mean "
                             "anything";
  EXPECT_LE(failures(registration::RegistrationSettings().tracking_retry_max_inlier_loss), 1);
}

// A display window that ends where the soft tissue is nearly black
// (config/robustness/saturated_window.yaml): the metal is clipped, and beside it the displayed
// edge moves outward by an amount that follows the tissue, or vanishes where the tissue is
// clipped too. Tracked as it is, the femoral component settles about 11 mm along the beam from
// frame 0 and the knee loses frames from frame 6 on (21 of the trial's 60 within the criteria);
// leaving out the outline beside clipped grey (EdgeMapSettings::clipped_grey_margin, the
// default) keeps these 16 frames within the criteria and the depth within a few millimetres.
TEST(Tracker, OutlineBesideClippedGreyKeepsASaturatedWindowOnTrack) {
  const VariantFrames variant("saturated_window", 15);
  struct Run {
    int successes = 0;
    double femur_depth_mm = 0.0;  // mean |error| along the beam
  };
  // The inlier tests as they were when this was found (before stop 55 they counted the outline
  // where it lies); counted at the edge offset, the unmasked run keeps more frames.
  const auto track = [&](double margin, bool inliers_at_edge_offset) {
    registration::RegistrationSettings settings;
    settings.edges.clipped_grey_margin = margin;
    settings.quality.inliers_at_edge_offset = inliers_at_edge_offset;
    Run run;
    for (const auto& errors : variant.trackedErrors(settings)) {
      run.successes += registration::meetsSuccessCriterion(errors[0]) &&
                               registration::meetsSuccessCriterion(errors[1])
                           ? 1
                           : 0;
      run.femur_depth_mm += std::abs(errors[0].translation_mm.z()) / variant.frames.size();
    }
    return run;
  };
  const Run as_is = track(0.0, false);
  ASSERT_LT(as_is.successes, static_cast<int>(variant.frames.size()) - 4)
      << "the clipped window must cost frames for the test to mean anything";
  ASSERT_GT(as_is.femur_depth_mm, 8.0);
  const double margin = registration::RegistrationSettings().edges.clipped_grey_margin;
  for (const bool at_offset : {false, true}) {
    SCOPED_TRACE(at_offset ? "inliers at the edge offset" : "inliers where the outline lies");
    const Run run = track(margin, at_offset);
    EXPECT_GE(run.successes, static_cast<int>(variant.frames.size()) - 1);
    EXPECT_LT(run.femur_depth_mm, 5.0);
  }
}

// A knee that travels through a fixed fluoroscope, as in a step-up or stair descent: 300 mm
// across the view in 20 frames, 16 mm between frames, from the trial's first frame on (no
// velocity to predict from). A registration from the last frame's poses does not capture that;
// the shift search (RegistrationSettings::tracking_shift_search_mm) moves the start across the
// view to where the bones' contours meet the frame's edges.
TEST(Tracker, FollowsAKneeThatTravelsAcrossTheViewBeyondTheRegistrationsReach) {
  sim::TrialSimulatorSettings travelling;
  travelling.motion.frames = 20;
  travelling.motion.max_flexion_deg = 60.0;
  travelling.motion.joint_travel_mm = Eigen::Vector3d(300.0, 0.0, 0.0);
  const VariantFrames trial(travelling, 6);
  for (const double reach_mm :
       {0.0, registration::RegistrationSettings().tracking_shift_search_mm}) {
    SCOPED_TRACE(reach_mm);
    registration::RegistrationSettings settings;
    settings.tracking_shift_search_mm = reach_mm;
    const auto errors = trial.trackedErrors(settings);
    const int off = VariantFrames::framesOffAfterTheFirst(errors);  // of frames 1-6
    if (reach_mm > 0.0) {
      EXPECT_EQ(off, 0);
    } else {
      EXPECT_GE(off, 5)
          << "the registration alone now follows the knee: the test needs more travel";
    }
  }
}

// A trial's second frame has no velocity to predict from, so a knee stepping down through the
// view (3.4 mm per frame, low dose, blur) starts it 3.4 mm off, and the continued registration
// settles the femoral component on a wrong pose that still fits most of its outline. The retry of
// a bone that fits worse than recently compares from the first frame on, so frame 1 is registered
// again with the full schedule; without that retry (tracking_retry_inlier_drop 0, as the history
// behaved before: it waited for three frames) the first frames stay off.
TEST(Tracker, RetriesTheSecondFrameWhereABoneFitsWorseThanInTheFirst) {
  sim::TrialSimulatorSettings step_down;
  step_down.seed = 2;
  step_down.motion.frames = 45;
  step_down.motion.max_flexion_deg = 85.0;
  step_down.motion.joint_travel_mm = Eigen::Vector3d(-120.0, 90.0, 30.0);
  step_down.detector.photons_per_pixel = 1500.0;
  step_down.detector.blur_sigma_px = 1.1;
  const VariantFrames trial(step_down, 3);
  for (const double drop : {0.0, registration::RegistrationSettings().tracking_retry_inlier_drop}) {
    SCOPED_TRACE(drop);
    registration::RegistrationSettings settings;
    settings.tracking_retry_inlier_drop = drop;
    const auto errors = trial.trackedErrors(settings);
    const int off = VariantFrames::framesOffAfterTheFirst(errors);  // of frames 1-3
    if (drop > 0.0) {
      EXPECT_EQ(off, 0);
    } else {
      EXPECT_GE(off, 2) << "the continued registration alone now finds frame 1: the test needs a "
                           "harder start";
    }
  }
}

// A bi-plane knee whose second beam runs 90 degrees from the first: in flexion that beam looks
// along the thigh, whose soft tissue shows the femoral component black on near-black, and the
// tray's outline fades where thigh and calf overlap (frames 13-22: up to four fifths of a view's
// outline with no edge within 15 px). The first view holds both bones, so the frames are good;
// counting those samples as misses flagged them as fitting worse than their recent frames.
TEST(Tracker, ABoneOneViewCannotShowIsNotFlaggedWhileTheOtherViewHoldsIt) {
  sim::TrialSimulatorSettings bi_plane;
  bi_plane.views = 2;
  bi_plane.view_separation_deg = 90.0;
  const VariantFrames trial(bi_plane, 22);
  for (const double unseen_px : {0.0, registration::QualitySettings().unseen_edge_distance_px}) {
    SCOPED_TRACE(unseen_px);
    registration::RegistrationSettings settings;
    settings.quality.unseen_edge_distance_px = unseen_px;
    constexpr int kFirst = 8;  // a few frames of history before the second view loses the outline
    registration::Tracker tracker(test_support::simulatedKneeRegistrar(trial.simulator, settings),
                                  {trial.frames[kFirst].femur, trial.frames[kFirst].tibia});
    int flagged = 0;
    int off = 0;
    for (std::size_t f = kFirst; f < trial.frames.size(); ++f) {
      const sim::SimulatedFrame& frame = trial.frames[f];
      std::vector<registration::ViewImage> views;
      for (std::size_t v = 0; v < frame.images.size(); ++v) {
        views.push_back({frame.images[v], trial.simulator.views()[v].camera});
      }
      const registration::TrackedFrame tracked = tracker.track(views);
      flagged += registration::statusTrouble(tracked.status) > 0 ? 1 : 0;
      off += registration::meetsSuccessCriterion(
                 registration::poseError(tracked.poses[0], frame.femur, trial.cameraFromFixed())) &&
                     registration::meetsSuccessCriterion(registration::poseError(
                         tracked.poses[1], frame.tibia, trial.cameraFromFixed()))
                 ? 0
                 : 1;
    }
    EXPECT_EQ(off, 0);
    if (unseen_px > 0.0) {
      EXPECT_LE(flagged, 1);
    } else {
      EXPECT_GE(flagged, 3) << "the second view keeps its outline now: the test needs another view";
    }
  }
}

// Two views: a frame is given up only when neither shows anything. With one view blank the
// other still holds the knee (the blank view has no edges to mislead the registration).
TEST(Tracker, GivesUpABiPlaneFrameOnlyWhenNoViewShowsAnything) {
  sim::TrialSimulatorSettings bi_plane;
  bi_plane.views = 2;
  const VariantFrames trial(bi_plane, 2);
  registration::Tracker tracker(test_support::simulatedKneeRegistrar(trial.simulator),
                                {trial.frames[0].femur, trial.frames[0].tibia});
  const auto views = [&](const sim::SimulatedFrame& frame, bool first_blank, bool second_blank) {
    std::vector<registration::ViewImage> out;
    for (std::size_t v = 0; v < frame.images.size(); ++v) {
      cv::Mat image = frame.images[v].clone();
      if ((v == 0 && first_blank) || (v == 1 && second_blank)) image.setTo(cv::Scalar(50));
      out.push_back({image, trial.simulator.views()[v].camera});
    }
    return out;
  };
  ASSERT_EQ(tracker.track(views(trial.frames[0], false, false)).status,
            (std::vector<std::string>{"ok", "ok"}));
  const registration::TrackedFrame both = tracker.track(views(trial.frames[1], true, true));
  EXPECT_EQ(both.status, (std::vector<std::string>{"lost", "lost"}));
  EXPECT_EQ(both.given_up,
            "no view shows anything (view 1: one grey level; view 2: one grey level)");
  const registration::TrackedFrame one = tracker.track(views(trial.frames[1], false, true));
  EXPECT_EQ(one.given_up, "");
  EXPECT_TRUE(registration::meetsSuccessCriterion(
      registration::poseError(one.poses[0], trial.frames[1].femur, trial.cameraFromFixed())));
  EXPECT_TRUE(registration::meetsSuccessCriterion(
      registration::poseError(one.poses[1], trial.frames[1].tibia, trial.cameraFromFixed())));
}

// Poses the user gave (the first frame, reinitialize) 25 mm off across the view, e.g. copied from
// another trial of the same knee: the shift search finds the knee in that very frame.
TEST(Tracker, FindsTheKneeWherePosesTheUserGaveAreOffAcrossTheView) {
  const VariantFrames trial(sim::TrialSimulatorSettings(), 0);
  const Pose world_from_camera = trial.camera().worldFromCamera();
  const Pose off =
      world_from_camera * Eigen::Translation3d(0.025, 0.0, 0.0) * world_from_camera.inverse();
  for (const double reach_mm :
       {0.0, registration::RegistrationSettings().tracking_shift_search_mm}) {
    SCOPED_TRACE(reach_mm);
    registration::RegistrationSettings settings;
    settings.tracking_shift_search_mm = reach_mm;
    registration::Tracker tracker(test_support::simulatedKneeRegistrar(trial.simulator, settings),
                                  {off * trial.frames[0].femur, off * trial.frames[0].tibia});
    const registration::TrackedFrame tracked =
        tracker.track({{trial.frames[0].images[0], trial.camera()}});
    const bool found = registration::meetsSuccessCriterion(registration::poseError(
                           tracked.poses[0], trial.frames[0].femur, trial.cameraFromFixed())) &&
                       registration::meetsSuccessCriterion(registration::poseError(
                           tracked.poses[1], trial.frames[0].tibia, trial.cameraFromFixed()));
    EXPECT_EQ(found, reach_mm > 0.0);
    EXPECT_EQ(tracked.status[0] == "ok" && tracked.status[1] == "ok", reach_mm > 0.0);
  }
}
