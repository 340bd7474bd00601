#include "fluoro_tracker/registration/image_shift_search.h"

#include <random>

#include "../test_support.h"
#include "fluoro_tracker/registration/pose_error.h"
#include "fluoro_tracker/sim/trial_simulator.h"
#include "simulated_knee.h"

using namespace fluoro_tracker;

namespace {

sim::TrialSimulatorSettings withViews(int views) {
  sim::TrialSimulatorSettings settings;
  settings.views = views;
  return settings;
}

struct TravelledFrame {
  sim::TrialSimulator simulator;
  sim::SimulatedFrame frame;
  std::vector<registration::BoneModel> bones;

  explicit TravelledFrame(int views = 1) : simulator(withViews(views)) {
    std::mt19937_64 rng(3);
    frame = simulator.render(20, &rng);
    bones = test_support::simulatedKneeBones(simulator);
  }
  const geometry::XrayCamera& camera() const { return simulator.views()[0].camera; }
  std::vector<registration::ViewImage> views() const {
    std::vector<registration::ViewImage> out;
    for (std::size_t v = 0; v < frame.images.size(); ++v) {
      out.push_back({frame.images[v], simulator.views()[v].camera});
    }
    return out;
  }
  // Both bones' true poses moved by `step` (m) in the view's camera frame.
  std::vector<geometry::Pose> moved(const Eigen::Vector3d& step) const {
    const geometry::Pose world_from_camera = camera().worldFromCamera();
    const geometry::Pose move =
        world_from_camera * Eigen::Translation3d(step) * world_from_camera.inverse();
    return {move * frame.femur, move * frame.tibia};
  }
};

}  // namespace

// Started 18 mm right of and 9 mm above where the knee is, the contours are moved back onto it
// to within the coarse map's pixel (about 1.3 mm at the knee), both bones by the same step.
TEST(ImageShiftSearch, MovesTheBonesBackOntoTheirOutlines) {
  const TravelledFrame t;
  const auto shifted =
      registration::posesShiftedToEdges(t.bones, t.moved(Eigen::Vector3d(0.018, -0.009, 0.0)),
                                        {{t.frame.images[0], t.camera()}}, {}, 0.06);
  ASSERT_TRUE(shifted.has_value());
  const geometry::Pose camera_from_fixed = t.camera().worldFromCamera().inverse();
  const std::vector<geometry::Pose> truth = {t.frame.femur, t.frame.tibia};
  for (int b = 0; b < 2; ++b) {
    const registration::PoseError error =
        registration::poseError((*shifted)[b], truth[b], camera_from_fixed);
    EXPECT_LT(std::hypot(error.translation_mm.x(), error.translation_mm.y()), 1.5) << b;
    EXPECT_NEAR(error.translation_mm.z(), 0.0, 1e-6) << b;
    EXPECT_NEAR(error.rotation_deg.norm(), 0.0, 1e-6) << b;
  }
  const geometry::Pose femur_in_tibia = truth[1].inverse() * truth[0];
  EXPECT_TRUE(((*shifted)[1].inverse() * (*shifted)[0]).isApprox(femur_in_tibia, 1e-9));
}

// From where the knee is, or with a reach too short to get there, nothing moves.
TEST(ImageShiftSearch, LeavesBonesThatAreOnTheirOutlinesOrOutOfReach) {
  const TravelledFrame t;
  const std::vector<registration::ViewImage> view = {{t.frame.images[0], t.camera()}};
  EXPECT_FALSE(
      registration::posesShiftedToEdges(t.bones, t.moved(Eigen::Vector3d::Zero()), view, {}, 0.06)
          .has_value());
  const auto short_reach = registration::posesShiftedToEdges(
      t.bones, t.moved(Eigen::Vector3d(0.04, 0.0, 0.0)), view, {}, 0.01);
  if (short_reach) {
    const geometry::Pose camera_from_fixed = t.camera().worldFromCamera().inverse();
    const double moved_mm =
        1e3 * ((camera_from_fixed * (*short_reach)[0]).translation() -
               (camera_from_fixed * t.moved(Eigen::Vector3d(0.04, 0.0, 0.0))[0]).translation())
                  .norm();
    EXPECT_LE(moved_mm, 10.0 + 1e-6);
  }
  const cv::Mat blank(t.frame.images[0].size(), t.frame.images[0].type(), cv::Scalar(128));
  EXPECT_FALSE(registration::posesShiftedToEdges(t.bones, t.moved(Eigen::Vector3d(0.018, 0.0, 0.0)),
                                                 {{blank, t.camera()}}, {}, 0.06)
                   .has_value());
}

// Two views see the knee's translation along each other's beams: their shifts give all three
// components, here of a knee 18 mm, 9 mm and 12 mm off along the lab's axes.
TEST(ImageShiftSearch, TwoViewsGiveTheTranslationAlongTheBeamToo) {
  const TravelledFrame t(2);
  const Eigen::Vector3d off(0.018, -0.009, 0.012);
  std::vector<geometry::Pose> started = {t.frame.femur, t.frame.tibia};
  for (auto& pose : started) pose.translation() += off;
  const auto shifted = registration::posesShiftedToEdges(t.bones, started, t.views(), {}, 0.06);
  ASSERT_TRUE(shifted.has_value());
  const std::vector<geometry::Pose> truth = {t.frame.femur, t.frame.tibia};
  for (int b = 0; b < 2; ++b) {
    EXPECT_LT(1e3 * ((*shifted)[b].translation() - truth[b].translation()).norm(), 2.0) << b;
    EXPECT_TRUE((*shifted)[b].linear().isApprox(truth[b].linear(), 1e-12)) << b;
  }
}
