#include "fluoro_tracker/registration/registrar.h"
#include "fluoro_tracker/kinematics/joint_types.h"

#include <array>
#include <cstdint>
#include <limits>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "../test_support.h"
#include "fluoro_tracker/io/trial_config.h"
#include "fluoro_tracker/io/trial_models.h"
#include "fluoro_tracker/registration/contour_distance_cost.h"
#include "fluoro_tracker/registration/frame_quality.h"
#include "fluoro_tracker/registration/mirror_ambiguity.h"
#include "fluoro_tracker/registration/pose_error.h"
#include "fluoro_tracker/registration/pose_increment.h"
#include "fluoro_tracker/sim/trial_simulator.h"
#include "kneel_study.h"
#include "simulated_knee.h"

using namespace fluoro_tracker;
using geometry::Pose;

namespace {

// One frame of a simulated single-view trial, with the trial's implants as bones.
struct SingleViewFrame {
  sim::TrialSimulator simulator;
  std::vector<registration::BoneModel> bones;
  sim::SimulatedFrame frame;
  std::vector<registration::ViewImage> views;

  SingleViewFrame(const sim::TrialSimulatorSettings& settings, int index, std::uint64_t seed)
      : simulator(settings), bones(test_support::simulatedKneeBones(simulator)) {
    std::mt19937_64 rng(seed);
    frame = simulator.render(index, &rng);
    views = {{frame.images[0], camera()}};
  }
  const geometry::XrayCamera& camera() const { return simulator.views()[0].camera; }
  Pose cameraFromFixed() const { return camera().worldFromCamera().inverse(); }
};

// Frame 5 of a 12-frame trial with the simulator's defaults.
struct Scene : SingleViewFrame {
  Scene() : SingleViewFrame(settings(), 5, 3) {}
  static sim::TrialSimulatorSettings settings() {
    sim::TrialSimulatorSettings s;
    s.motion.frames = 12;
    return s;
  }
};

Pose offset(const Pose& p, const Eigen::Vector3d& shift_m, const Eigen::Vector3d& angles_rad) {
  Pose out = p;
  out.translation() += shift_m;
  out.linear() = p.linear() * geometry::rotationX(angles_rad.x()) *
                 geometry::rotationY(angles_rad.y()) * geometry::rotationZ(angles_rad.z());
  return out;
}

// The knee between the scene's femur (bone 0) and tibia (bone 1), with the default ligament
// springs and no contact.
registration::JointModel kneeJoint() {
  registration::JointModel knee;
  knee.name = "knee";
  knee.parent = 0;
  knee.child = 1;
  return knee;
}

// The same registration to the bit: poses, final cost and cost evaluations (e.g. on one thread
// and on two).
void expectSameRegistration(const registration::RegistrationResult& a,
                            const registration::RegistrationResult& b) {
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (std::size_t k = 0; k < a.poses.size(); ++k) {
    EXPECT_TRUE(a.poses[k].matrix() == b.poses[k].matrix()) << "bone " << k;
  }
  EXPECT_EQ(a.final_cost, b.final_cost);
  EXPECT_EQ(a.cost_evaluations, b.cost_evaluations);
}

// The scene with the tibial tray started on its mirror pose (through the plane along the beam),
// which the single view cannot tell from the truth; the femur starts at its truth.
struct MirroredTrayStart : Scene {
  std::vector<Pose> truth = {frame.femur, frame.tibia};
  std::vector<Pose> start = {
      truth[0],
      camera().worldFromCamera() * registration::mirroredAcrossBeam(cameraFromFixed() * truth[1])};
};

// Both bones of the scene 3.6-4.5 mm and 3 deg off in total.
std::vector<Pose> perturbedStarts(const std::vector<Pose>& truth) {
  return {offset(truth[0], {0.0015, -0.001, 0.002}, {0.03, -0.04, 0.03}),
          offset(truth[1], {-0.001, 0.0015, -0.002}, {-0.04, 0.03, -0.03})};
}

// The dissertation's success criterion about the bone's axes: 2 deg about X and Z, 3 deg about Y.
void expectWithinRotationCriterion(const Pose& result, const Pose& truth, const std::string& name) {
  const Eigen::AngleAxisd delta(truth.linear().transpose() * result.linear());
  const Eigen::Vector3d axis_deg = geometry::radToDeg(delta.angle()) * delta.axis();
  EXPECT_LT(std::abs(axis_deg.x()), 2.0) << name;
  EXPECT_LT(std::abs(axis_deg.y()), 3.0) << name;
  EXPECT_LT(std::abs(axis_deg.z()), 2.0) << name;
}

}  // namespace

TEST(Registrar, RecoversKnownPosesOnASimulatedFrame) {
  const Scene scene;
  const registration::Registrar registrar(scene.bones, registration::RegistrationSettings());
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const std::vector<Pose> start = perturbedStarts(truth);
  const auto result = registrar.solve(scene.views, start);
  ASSERT_EQ(result.poses.size(), 2u);
  EXPECT_GT(result.cost_evaluations, 0);
  for (int b = 0; b < 2; ++b) {
    const Eigen::Vector3d error = result.poses[b].translation() - truth[b].translation();
    EXPECT_LT(std::hypot(error.x(), error.y()), 0.0005) << scene.bones[b].name;  // in-plane
    expectWithinRotationCriterion(result.poses[b], truth[b], scene.bones[b].name);
    // The start was 3.6-4.5 mm and 3 deg off in total; in-plane it is now far closer.
    const Eigen::Vector3d start_error = start[b].translation() - truth[b].translation();
    EXPECT_LT(std::hypot(error.x(), error.y()),
              0.25 * std::hypot(start_error.x(), start_error.y()));
  }
}

// The rendered-edge option (RegistrationSettings::rendered_edges) registers the same frame as
// well, and does take part: its poses are not corner rounding's.
TEST(Registrar, RecoversKnownPosesWithRenderedEdges) {
  const Scene scene;
  registration::RegistrationSettings settings;
  settings.rendered_edges.enabled = true;
  const registration::Registrar rendered(scene.bones, settings);
  const registration::Registrar rounded(scene.bones, registration::RegistrationSettings());
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const std::vector<Pose> start = perturbedStarts(truth);
  const auto result = rendered.solve(scene.views, start);
  const auto rounded_result = rounded.solve(scene.views, start);
  double moved_m = 0.0;
  for (int b = 0; b < 2; ++b) {
    const Eigen::Vector3d error = result.poses[b].translation() - truth[b].translation();
    EXPECT_LT(std::hypot(error.x(), error.y()), 0.0005) << scene.bones[b].name;
    EXPECT_LT(std::abs(error.z()), 0.005) << scene.bones[b].name;  // along the beam
    expectWithinRotationCriterion(result.poses[b], truth[b], scene.bones[b].name);
    moved_m = std::max(
        moved_m, (result.poses[b].translation() - rounded_result.poses[b].translation()).norm());
  }
  EXPECT_GT(moved_m, 1e-5);
  settings.rendered_edges.saturation_mm = 0.0;
  EXPECT_THROW_WITH(registration::Registrar(scene.bones, settings), "rendered_edges");
}

// The finer scales' edge maps built on a second thread are the maps built in turn: the same
// solution to the last bit, crude starts (three scales) and the standard two.
TEST(Registrar, PrefetchingEdgeMapsLeavesTheResultUnchanged) {
  const Scene scene;
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const std::vector<Pose> start = perturbedStarts(truth);
  for (const std::vector<double>& scales :
       {std::vector<double>{0.5, 1.0}, std::vector<double>{0.25, 0.5, 1.0}}) {
    registration::RegistrationSettings settings;
    settings.scales = scales;
    settings.threads = 2;
    const auto prefetched =
        registration::Registrar(scene.bones, settings).solve(scene.views, start);
    settings.threads = 1;
    const auto in_turn = registration::Registrar(scene.bones, settings).solve(scene.views, start);
    EXPECT_EQ(prefetched.final_cost, in_turn.final_cost);
    for (int b = 0; b < 2; ++b) {
      EXPECT_TRUE(prefetched.poses[b].matrix() == in_turn.poses[b].matrix()) << b;
    }
    EXPECT_TRUE(registration::meetsSuccessCriterion(
        registration::poseError(prefetched.poses[1], truth[1], scene.cameraFromFixed())));
  }
  registration::RegistrationSettings none;
  none.threads = 0;
  EXPECT_THROW_WITH(registration::Registrar(scene.bones, none), "threads must be >= 1");
}

// The tibia starts pushed 2 mm up into the femoral component (and both bones off in other
// ways). With contact the registrar ends with the surfaces touching, not interpenetrating, and
// reports the contact figures.
TEST(Registrar, ContactRelievesPenetrationAndIsReported) {
  const Scene scene;
  const auto& implants = scene.simulator.implants();
  auto contact = std::make_shared<constraints::ArticularContact>(
      implants.femoral_component, implants.tibial_insert, constraints::ContactSettings());
  registration::JointModel knee = kneeJoint();
  knee.ligaments.enabled = false;
  knee.contact = contact;
  const registration::Registrar with_contact(scene.bones, registration::RegistrationSettings(),
                                             {knee});
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const Eigen::Vector3d up = truth[1].linear().col(1);  // the tibia's superior axis
  const std::vector<Pose> start = {offset(truth[0], {0.0005, 0.0, 0.0}, {0.01, 0.0, -0.01}),
                                   offset(truth[1], 0.002 * up, {0.0, 0.02, 0.01})};
  ASSERT_GT(contact->figures(start[0], start[1]).max_depth_m, 0.0015);
  const registration::RegistrationResult result = with_contact.solve(scene.views, start);
  ASSERT_EQ(result.joints.size(), 1u);
  ASSERT_TRUE(result.joints[0].has_contact);
  EXPECT_LT(result.joints[0].contact.max_depth_m, 1e-4);
  // Every figure of the returned solution, FCL's too (added to the solution kept only).
  const constraints::ContactFigures at_result = contact->figures(result.poses[0], result.poses[1]);
  EXPECT_NEAR(result.joints[0].contact.max_depth_m, at_result.max_depth_m, 1e-12);
  EXPECT_EQ(result.joints[0].contact.in_collision, at_result.in_collision);
  EXPECT_NEAR(result.joints[0].contact.min_distance_m, at_result.min_distance_m, 1e-12);
  // FCL either found the surfaces in collision or measured a gap (the defaults, false and 0,
  // would mean it was never asked).
  EXPECT_TRUE(result.joints[0].contact.in_collision ||
              result.joints[0].contact.min_distance_m > 0.0);
  const Pose camera_from_fixed = scene.cameraFromFixed();
  for (int b = 0; b < 2; ++b) {
    EXPECT_TRUE(registration::meetsSuccessCriterion(
        registration::poseError(result.poses[b], truth[b], camera_from_fixed)))
        << scene.bones[b].name;
  }
  // Edge offsets are estimated per bone and view, and stay small (a fraction of a pixel).
  ASSERT_EQ(result.edge_offsets_px.size(), 2u);
  for (const auto& per_view : result.edge_offsets_px) EXPECT_LT(std::abs(per_view[0]), 1.5);
}

// The edge offset is held at zero while the contour may still be pixels off: with a single
// outer iteration it never becomes free; without the hold it is estimated from the start.
TEST(Registrar, EdgeOffsetIsHeldUntilTheSecondOuterIteration) {
  const Scene scene;
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const std::vector<Pose> start = {offset(truth[0], {0.001, -0.001, 0.002}, {0.02, -0.02, 0.02}),
                                   offset(truth[1], {-0.001, 0.001, -0.002}, {-0.02, 0.02, 0.0})};
  const auto& views = scene.views;
  registration::RegistrationSettings settings;
  settings.outer_iterations = 1;
  settings.mirror_check.enabled = false;
  const auto held = registration::Registrar(scene.bones, settings).solve(views, start);
  settings.edge_offset_hold = false;
  const auto free = registration::Registrar(scene.bones, settings).solve(views, start);
  ASSERT_EQ(held.edge_offsets_px.size(), 2u);
  ASSERT_EQ(free.edge_offsets_px.size(), 2u);
  double largest_free = 0.0;
  for (int b = 0; b < 2; ++b) {
    EXPECT_EQ(held.edge_offsets_px[b][0], 0.0) << scene.bones[b].name;
    largest_free = std::max(largest_free, std::abs(free.edge_offsets_px[b][0]));
  }
  EXPECT_GT(largest_free, 0.01);
}

// A prior on a bone's edge offset (e.g. a tracker's estimate from earlier frames) starts the
// offset at its mean and holds it there when it is tight; a malformed one is refused.
TEST(Registrar, EdgeOffsetPriorsAreHonoured) {
  const Scene scene;
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const auto& views = scene.views;
  registration::RegistrationSettings settings;
  settings.mirror_check.enabled = false;
  const registration::Registrar registrar(scene.bones, settings);
  registration::EdgeOffsetPriors priors(2, std::vector<registration::EdgeOffsetPrior>(1));
  priors[0][0] = {0.4, 1e-3};
  priors[1][0] = {-0.3, 1e-3};
  const auto result = registrar.solve(views, truth, {}, priors);
  ASSERT_EQ(result.edge_offsets_px.size(), 2u);
  EXPECT_NEAR(result.edge_offsets_px[0][0], 0.4, 0.01);
  EXPECT_NEAR(result.edge_offsets_px[1][0], -0.3, 0.01);
  priors[1][0].sigma_px = 0.0;
  EXPECT_THROW_WITH(registrar.solve(views, truth, {}, priors), "edge offset priors");
  priors.pop_back();
  EXPECT_THROW_WITH(registrar.solve(views, truth, {}, priors), "edge offset priors");
  // Likewise a tracked frame's recent contour spreads (RotationRetrySettings): one per bone.
  EXPECT_THROW_WITH(registrar.solve(views, truth, {}, {}, {0.3}), "recent contour spreads");
}

// Ligament springs act only outside the joint's envelope: a registration result inside the knee
// defaults is left unchanged by them. Solved from that result with and without the springs, the
// answers are identical. (From a perturbed start they may differ: trial steps along the beam,
// which the image barely sees, can leave the envelope on the way, and there the springs act.)
TEST(Registrar, LigamentsLeaveResultsInsideTheEnvelopeUnchanged) {
  const Scene scene;
  registration::JointModel knee = kneeJoint();
  // The mirror check (its own test below) may choose another pose than the image alone would.
  registration::RegistrationSettings no_mirror_check;
  no_mirror_check.mirror_check.enabled = false;
  const registration::Registrar with_ligaments(scene.bones, no_mirror_check, {knee});
  const registration::Registrar without(scene.bones, registration::RegistrationSettings());
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const auto coordinates = knee.coordinates(truth[0], truth[1]);
  ASSERT_GT(coordinates.flexion_rad, 0.0);
  ASSERT_LT(std::abs(geometry::radToDeg(coordinates.adduction_rad)), 2.0);
  const std::vector<Pose> start = {offset(truth[0], {0.001, -0.001, 0.002}, {0.02, -0.03, 0.02}),
                                   offset(truth[1], {-0.001, 0.001, -0.002}, {-0.03, 0.02, -0.02})};
  const auto& views = scene.views;
  const auto image_only = without.solve(views, start);
  const auto inside = knee.coordinates(image_only.poses[0], image_only.poses[1]);
  ASSERT_EQ(registration::envelopeViolation(knee.ligaments, inside), 0.0)
      << "the image-only result must lie inside the envelope for this test";
  const auto a = with_ligaments.solve(views, image_only.poses);
  const auto b = without.solve(views, image_only.poses);
  for (int k = 0; k < 2; ++k) {
    EXPECT_LT((a.poses[k].translation() - b.poses[k].translation()).norm(), 1e-6);
    EXPECT_LT(geometry::rotationAngleBetween(a.poses[k].linear(), b.poses[k].linear()), 1e-5);
  }
  ASSERT_EQ(a.joints.size(), 1u);
  EXPECT_FALSE(a.joints[0].has_contact);
  EXPECT_EQ(a.joints[0].quality.envelope_violation, 0.0);
  EXPECT_NEAR(a.joints[0].coordinates.flexion_rad, coordinates.flexion_rad,
              geometry::degToRad(2.0));
}

// From a start whose tibia is tilted 12 deg about its anterior axis (beyond the 3 deg varus-
// valgus envelope), the image alone settles in a false minimum near 10 deg; the springs pull the
// joint toward its envelope (they are a penalty, not a global search: how far depends on the
// stiffness against the image's barrier).
TEST(Registrar, LigamentsPullAJointTowardItsEnvelope) {
  const Scene scene;
  registration::JointModel knee = kneeJoint();
  // The springs alone are under test: the mirror check would also free the image-only
  // registration from this false minimum (measured: 0.5 deg adduction).
  registration::RegistrationSettings settings;
  settings.mirror_check.enabled = false;
  const registration::Registrar registrar(scene.bones, settings, {knee});
  knee.ligaments.enabled = false;
  const registration::Registrar image_only(scene.bones, settings, {knee});
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const std::vector<Pose> start = {
      truth[0], offset(truth[1], Eigen::Vector3d::Zero(), {geometry::degToRad(12.0), 0.0, 0.0})};
  ASSERT_GT(std::abs(knee.coordinates(start[0], start[1]).adduction_rad), geometry::degToRad(10.0));
  const auto& views = scene.views;
  const double with_springs = std::abs(
      geometry::radToDeg(registrar.solve(views, start).joints[0].coordinates.adduction_rad));
  const double without = std::abs(
      geometry::radToDeg(image_only.solve(views, start).joints[0].coordinates.adduction_rad));
  EXPECT_GT(without, 5.0);
  EXPECT_LT(with_springs, without - 1.0);
}

// Every joint type's springs act on its own coordinates inside the solve: the scene's implants
// joined as a patellofemoral joint (springs on the Bull et al. angles, through frames turned
// about Z) and as a glenohumeral one (springs on the ISB's Y-X-Y angles). With one angle's bounds
// 4 deg beyond its value at the image-only result, on an axis across the beam that the view
// sees poorly, the springs pull that angle toward its bound, and the result's envelope violation
// is its remaining distance from the bound.
TEST(Registrar, EveryJointTypesSpringsActOnItsOwnCoordinates) {
  const Scene scene;
  registration::RegistrationSettings settings;
  settings.mirror_check.enabled = false;  // a knee's rule; these are not knees
  const auto& views = scene.views;
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  // Patellofemoral lateral tilt (about the floating axis), glenohumeral axial rotation.
  for (const auto& [type, angle] : {std::pair{kinematics::JointType::kPatellofemoral, 1},
                                    std::pair{kinematics::JointType::kGlenohumeral, 2}}) {
    const std::string name = kinematics::jointTypeName(type);
    registration::JointModel joint = kneeJoint();
    joint.type = type;
    joint.ligaments.bounds = {};
    joint.ligaments.enabled = false;
    const auto angle_deg = [&](const registration::RegistrationResult& r) {
      const auto c = joint.reportedCoordinates(r.poses[0], r.poses[1]);
      const double angles[3] = {c.flexion_rad, c.adduction_rad, c.internal_rotation_rad};
      return geometry::radToDeg(angles[angle]);
    };
    const auto free = registration::Registrar(scene.bones, settings, {joint}).solve(views, truth);
    const double lower = angle_deg(free) + 4.0;
    joint.ligaments.enabled = true;
    joint.ligaments.bounds[angle] = {lower, lower + 20.0};
    const auto pulled =
        registration::Registrar(scene.bones, settings, {joint}).solve(views, free.poses);
    EXPECT_GT(angle_deg(pulled), angle_deg(free) + 1.0) << name;
    // The glenohumeral axial spring acts on axial rotation + (1 - w) x plane of elevation
    // (glenohumeral_springs.h): that share is the only difference allowed beyond rounding.
    const auto c = joint.reportedCoordinates(pulled.poses[0], pulled.poses[1]);
    const double sin_squared = std::pow(std::sin(c.adduction_rad), 2);
    const double pole = std::pow(std::sin(geometry::degToRad(2.0)), 2);
    const double blend =
        type == kinematics::JointType::kGlenohumeral
            ? pole / (sin_squared + pole) * std::abs(geometry::radToDeg(c.flexion_rad))
            : 0.0;
    EXPECT_NEAR(pulled.joints[0].quality.envelope_violation,
                std::max(0.0, lower - angle_deg(pulled)), blend + 1e-3)
        << name;
  }
}

// A ligament bundle acts only when stretched. Here one runs across the joint along the beam
// (from the femur's lateral side to the tibia's medial side; not an anatomical ligament, but
// along the direction the single view sees least, so the image hardly resists it). Slack at the
// image-only result, it changes nothing; 3 mm too short, it pulls the bones until it is nearly
// slack, and the joint's envelope violation reports what stretch is left.
TEST(Registrar, LigamentBundlesActOnlyWhenStretched) {
  const Scene scene;
  registration::RegistrationSettings settings;
  settings.mirror_check.enabled = false;  // the bundle alone is under test
  registration::JointModel knee = kneeJoint();
  const auto& views = scene.views;
  const registration::Registrar without(scene.bones, settings, {knee});
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const auto reference = without.solve(views, truth);
  ASSERT_EQ(reference.joints[0].quality.envelope_violation, 0.0);
  constraints::LigamentBundle bundle;
  bundle.name = "across";
  bundle.parent_insertion_m = Eigen::Vector3d(0.0, 0.0, 0.04);
  bundle.child_insertion_m = Eigen::Vector3d(0.0, -0.01, -0.04);
  const double length = bundle.length(reference.poses[0], reference.poses[1]);

  bundle.slack_length_m = length + 0.005;
  knee.ligaments.bundles = {bundle};
  const auto slack =
      registration::Registrar(scene.bones, settings, {knee}).solve(views, reference.poses);
  const auto plain = without.solve(views, reference.poses);
  for (int k = 0; k < 2; ++k) {
    EXPECT_LT((slack.poses[k].translation() - plain.poses[k].translation()).norm(), 1e-6);
    EXPECT_LT(geometry::rotationAngleBetween(slack.poses[k].linear(), plain.poses[k].linear()),
              1e-5);
  }

  bundle.slack_length_m = length - 0.003;
  knee.ligaments.bundles = {bundle};
  const auto pulled =
      registration::Registrar(scene.bones, settings, {knee}).solve(views, reference.poses);
  ASSERT_NEAR(bundle.stretchMm(reference.poses[0], reference.poses[1]), 3.0, 1e-9);
  const double stretch = bundle.stretchMm(pulled.poses[0], pulled.poses[1]);
  EXPECT_LT(stretch, 1.0);
  EXPECT_GE(pulled.joints[0].quality.envelope_violation, stretch);
}

// A stage's image weights scale each bone's image terms: with the tibia's at 0 (and no joint to
// move it), the tibia stays where it started while the femur is registered.
TEST(Registrar, StageImageWeightsApplyPerBone) {
  const Scene scene;
  registration::RegistrationSettings settings;
  registration::RegistrationStage stage;
  stage.image_weights = {{"tibia", 0.0}};
  settings.stages = {stage};
  const registration::Registrar registrar(scene.bones, settings);
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const std::vector<Pose> start = {offset(truth[0], {0.001, -0.001, 0.0}, {0.02, 0.0, 0.0}),
                                   offset(truth[1], {-0.001, 0.001, 0.0}, {0.0, 0.02, 0.0})};
  const auto result = registrar.solve(scene.views, start);
  EXPECT_LT((result.poses[1].translation() - start[1].translation()).norm(), 1e-9);
  const Eigen::Vector3d femur_error = result.poses[0].translation() - truth[0].translation();
  EXPECT_LT(std::hypot(femur_error.x(), femur_error.y()), 0.0005);
}

// The pose covariance is symmetric, positive, and says what single-plane registration knows:
// translation along the beam (optical z) is far less certain than across it.
TEST(Registrar, CovarianceIsLargestAlongTheBeam) {
  const Scene scene;
  registration::RegistrationSettings settings;
  settings.compute_covariance = true;
  const registration::Registrar registrar(scene.bones, settings);
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const auto result = registrar.solve(
      scene.views, {offset(truth[0], {0.0005, 0.0, 0.001}, Eigen::Vector3d::Zero()), truth[1]});
  ASSERT_EQ(result.covariances.size(), 2u);
  for (int b = 0; b < 2; ++b) {
    ASSERT_TRUE(result.covariance_valid[b]) << b;
    const Eigen::Matrix<double, 6, 6>& c = result.covariances[b];
    EXPECT_LT((c - c.transpose()).norm(), 1e-9 * c.norm());
    EXPECT_GT(c.selfadjointView<Eigen::Lower>().eigenvalues().minCoeff(), -1e-12 * c.norm());
    EXPECT_GT(c(2, 2), 10.0 * c(0, 0)) << scene.bones[b].name;
    EXPECT_GT(c(2, 2), 10.0 * c(1, 1)) << scene.bones[b].name;
    // In-plane standard deviation well under a millimetre.
    EXPECT_LT(std::sqrt(c(0, 0)), 0.001);
    // Neighbouring contour samples' residuals are correlated (blur, the outline's shape), so
    // the covariance is widened by more than one sample's worth, and the reported
    // out-of-plane standard deviation then covers the actual error along the beam.
    const double correlation = result.quality[b].residual_correlation_samples;
    EXPECT_GT(correlation, 1.5) << scene.bones[b].name;
    EXPECT_LT(correlation, 201.0) << scene.bones[b].name;
    const Eigen::Vector3d error_in_camera =
        scene.cameraFromFixed().linear() * (result.poses[b].translation() - truth[b].translation());
    EXPECT_LT(std::abs(error_in_camera.z()), 3.0 * result.quality[b].out_of_plane_sd_m)
        << scene.bones[b].name;
  }
  // Off by default.
  EXPECT_TRUE(registration::Registrar(scene.bones, registration::RegistrationSettings())
                  .solve(scene.views, truth)
                  .covariances.empty());
}

// The covariance's allowance for an edge offset that changes across the outline: it leaves the
// poses alone, adds a positive part that grows with the square of its standard deviation, and
// widens the standard deviation along the beam (a gradient moves the outline's ends apart or
// together, as depth does).
TEST(Registrar, CovarianceAllowsForAnEdgeOffsetGradientAcrossTheOutline) {
  const Scene scene;
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const std::vector<Pose> start = {offset(truth[0], {0.0005, 0.0, 0.001}, Eigen::Vector3d::Zero()),
                                   truth[1]};
  const auto solve = [&](double gradient_sd_px) {
    registration::RegistrationSettings settings;
    settings.compute_covariance = true;
    settings.covariance_offset_gradient_sd_px = gradient_sd_px;
    return registration::Registrar(scene.bones, settings).solve(scene.views, start);
  };
  const auto without = solve(0.0);
  const auto with = solve(0.2);
  const auto doubled = solve(0.4);
  for (int b = 0; b < 2; ++b) {
    const std::string name = scene.bones[b].name;
    ASSERT_TRUE(with.covariance_valid[b] && without.covariance_valid[b]) << name;
    EXPECT_LT((with.poses[b].translation() - without.poses[b].translation()).norm(), 1e-12);
    EXPECT_TRUE(without.offset_gradient_covariances[b].isZero()) << name;
    const Eigen::Matrix<double, 6, 6>& added = with.offset_gradient_covariances[b];
    EXPECT_GT(added.norm(), 0.0) << name;
    EXPECT_LT((with.covariances[b] - without.covariances[b] - added).norm(), 1e-6 * added.norm())
        << name;
    EXPECT_GT(added.selfadjointView<Eigen::Lower>().eigenvalues().minCoeff(), -1e-12 * added.norm())
        << name;
    EXPECT_NEAR(doubled.offset_gradient_covariances[b].norm(), 4.0 * added.norm(),
                1e-6 * added.norm())
        << name;
    EXPECT_GT(with.quality[b].out_of_plane_sd_m, 1.01 * without.quality[b].out_of_plane_sd_m)
        << name;
  }
}

// The parent-relative parameterisation (the child's increment relative to its parent's) is a
// change of variables: from the same start it ends in the same minimum as the absolute one
// (Levenberg-Marquardt's damped steps differ, so within 0.2 mm and 0.5 deg, measured 0.25 deg),
// and the child's covariance, carried through the composition, agrees within 10 %.
TEST(Registrar, ParentRelativeParameterisationReachesTheSameRegistration) {
  const Scene scene;
  registration::RegistrationSettings settings;
  settings.compute_covariance = true;
  settings.mirror_check.enabled = false;
  const registration::Registrar absolute(scene.bones, settings, {kneeJoint()});
  settings.parameterisation = registration::RegistrationSettings::Parameterisation::kParentRelative;
  const registration::Registrar relative(scene.bones, settings, {kneeJoint()});
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const std::vector<Pose> start = {offset(truth[0], {0.001, -0.001, 0.002}, {0.02, -0.03, 0.02}),
                                   offset(truth[1], {-0.001, 0.001, -0.002}, {-0.03, 0.02, -0.02})};
  const auto& views = scene.views;
  const auto a = absolute.solve(views, start);
  const auto r = relative.solve(views, start);
  for (int b = 0; b < 2; ++b) {
    const Eigen::Vector3d error = r.poses[b].translation() - truth[b].translation();
    EXPECT_LT(std::hypot(error.x(), error.y()), 0.0005) << b;
    EXPECT_LT((r.poses[b].translation() - a.poses[b].translation()).norm(), 2e-4) << b;
    EXPECT_LT(geometry::rotationAngleBetween(r.poses[b].linear(), a.poses[b].linear()),
              geometry::degToRad(0.5))
        << b;
    ASSERT_TRUE(r.covariance_valid[b]) << b;
    for (int k = 0; k < 6; ++k) {
      EXPECT_NEAR(r.covariances[b](k, k), a.covariances[b](k, k), 0.1 * a.covariances[b](k, k))
          << "bone " << b << " diagonal " << k;
    }
  }
}

// Started with the tibial tray on its mirror pose (through the plane along the beam), which the
// single view cannot tell from the truth, the registration stays there without the mirror
// check; with it, the pose nearer neutral adduction and axial rotation, the truth, is chosen.
TEST(Registrar, MirrorCheckChoosesTheTrayPoseNearerNeutral) {
  const MirroredTrayStart scene;
  const std::vector<Pose>& truth = scene.truth;
  const std::vector<Pose>& start = scene.start;
  const Pose camera_from_fixed = scene.cameraFromFixed();
  const registration::JointModel knee = kneeJoint();
  registration::RegistrationSettings settings;
  // Corner rounding off: with it, the tray's corners tell this view's mirror from the truth and
  // the registration from the mirror start finds the truth unchecked.
  settings.corner_rounding = false;
  // Neutral as the registrar measures it.
  const auto deviation = [&](const std::vector<Pose>& poses) {
    return registration::neutralDeviation(
        knee.ligaments, knee.coordinates(poses[0], poses[1]),
        settings.mirror_check.neutral_internal_rotation_per_flexion);
  };
  ASSERT_GT(deviation(start), deviation(truth));
  settings.mirror_check.enabled = false;
  // The mirror check alone (the rotation retry also frees the tray here).
  settings.depth_retry.enabled = false;
  settings.rotation_retry.enabled = false;
  const std::vector<registration::ViewImage>& views = scene.views;
  const auto unchecked = registration::Registrar(scene.bones, settings, {knee}).solve(views, start);
  ASSERT_FALSE(registration::meetsSuccessCriterion(
      registration::poseError(unchecked.poses[1], truth[1], camera_from_fixed)))
      << "the mirror must be a distinct pose in this view for the test to mean anything";
  settings.mirror_check.enabled = true;
  const auto checked = registration::Registrar(scene.bones, settings, {knee}).solve(views, start);
  for (int b = 0; b < 2; ++b) {
    EXPECT_TRUE(registration::meetsSuccessCriterion(
        registration::poseError(checked.poses[b], truth[b], camera_from_fixed)))
        << scene.bones[b].name;
  }
  // The check's second solve is counted.
  EXPECT_GT(checked.cost_evaluations, unchecked.cost_evaluations);

  // The mirror replaces the solution only when its joint is nearer neutral by more than
  // min_neutral_gain: just above this frame's gain, the check keeps the mirror start's result.
  const double gain = deviation(unchecked.poses) - deviation(checked.poses);
  ASSERT_GT(gain, settings.mirror_check.min_neutral_gain);
  settings.mirror_check.min_neutral_gain = gain + 0.01;
  const auto kept = registration::Registrar(scene.bones, settings, {knee}).solve(views, start);
  EXPECT_FALSE(registration::meetsSuccessCriterion(
      registration::poseError(kept.poses[1], truth[1], camera_from_fixed)));
  EXPECT_NEAR(deviation(kept.poses), deviation(unchecked.poses), 1e-9);

  // A candidate whose cost after an outer iteration exceeds abandon_cost_ratio x the solution's
  // is stopped there and not kept: far below 1, every candidate is, and the first solution stays.
  settings.mirror_check.min_neutral_gain = registration::MirrorCheckSettings().min_neutral_gain;
  settings.mirror_check.abandon_cost_ratio = 1e-6;
  const auto gated = registration::Registrar(scene.bones, settings, {knee}).solve(views, start);
  EXPECT_NEAR(deviation(gated.poses), deviation(unchecked.poses), 1e-9);
  EXPECT_LT(gated.cost_evaluations, checked.cost_evaluations);
  EXPECT_GT(gated.cost_evaluations, unchecked.cost_evaluations);
  // ... and one whose joint is farther from neutral than it must end by more than
  // abandon_deviation_excess: asked to end all but exactly neutral, no candidate can, and the
  // gate stops them all early.
  settings.mirror_check.abandon_cost_ratio = 1e9;
  settings.mirror_check.min_neutral_gain = deviation(unchecked.poses) - 1e-6;
  settings.mirror_check.abandon_deviation_excess = 1e9;
  settings.mirror_check.start_deviation_excess = 1e9;
  const auto ungated = registration::Registrar(scene.bones, settings, {knee}).solve(views, start);
  settings.mirror_check.abandon_deviation_excess = 1e-6;
  const auto far = registration::Registrar(scene.bones, settings, {knee}).solve(views, start);
  EXPECT_NEAR(deviation(ungated.poses), deviation(unchecked.poses), 1e-9);
  EXPECT_NEAR(deviation(far.poses), deviation(unchecked.poses), 1e-9);
  EXPECT_LT(far.cost_evaluations, ungated.cost_evaluations);
  // ... and one that starts that far (start_deviation_excess) is not solved at all: the
  // solution and its cost evaluations are the unchecked registration's.
  settings.mirror_check.abandon_deviation_excess = 1e9;
  settings.mirror_check.start_deviation_excess = 1e-6;
  const auto skipped = registration::Registrar(scene.bones, settings, {knee}).solve(views, start);
  EXPECT_NEAR(deviation(skipped.poses), deviation(unchecked.poses), 1e-9);
  EXPECT_EQ(skipped.cost_evaluations, unchecked.cost_evaluations);
}

// A mirror candidate still in the running after its outer iterations is continued
// (MirrorCheckSettings::continued_outer_iterations).
TEST(Registrar, MirrorCheckContinuesACandidateStillInTheRunning) {
  const MirroredTrayStart scene;
  const std::vector<Pose>& truth = scene.truth;
  const Pose camera_from_fixed = scene.cameraFromFixed();
  const registration::JointModel knee = kneeJoint();
  registration::RegistrationSettings settings;
  settings.corner_rounding = false;      // as in MirrorCheckChoosesTheTrayPoseNearerNeutral
  settings.depth_retry.enabled = false;  // the mirror check alone
  const auto solve = [&](int outer, int continued) {
    settings.mirror_check.outer_iterations = outer;
    settings.mirror_check.continued_outer_iterations = continued;
    return registration::Registrar(scene.bones, settings, {knee}).solve(scene.views, scene.start);
  };
  // One outer iteration leaves the kept candidate short of its minimum; continued by two, it
  // is solved exactly as with three.
  const auto cut_short = solve(1, 0);
  const auto continued = solve(1, 2);
  const auto three = solve(3, 0);
  for (int b = 0; b < 2; ++b) {
    EXPECT_TRUE(registration::meetsSuccessCriterion(
        registration::poseError(continued.poses[b], truth[b], camera_from_fixed)))
        << scene.bones[b].name;
  }
  EXPECT_LT(continued.final_cost, 0.9 * cut_short.final_cost);
  expectSameRegistration(continued, three);

  // A candidate that cannot be kept (asked to end all but exactly neutral) is not continued.
  settings.mirror_check.enabled = false;
  const auto unchecked = solve(1, 0);
  settings.mirror_check.enabled = true;
  const auto deviation = [&](const std::vector<Pose>& poses) {
    return registration::neutralDeviation(
        knee.ligaments, knee.coordinates(poses[0], poses[1]),
        settings.mirror_check.neutral_internal_rotation_per_flexion);
  };
  settings.mirror_check.min_neutral_gain = deviation(unchecked.poses) - 1e-6;
  settings.mirror_check.abandon_deviation_excess = 1e9;
  settings.mirror_check.start_deviation_excess = 1e9;
  const auto hopeless = solve(1, 0);
  expectSameRegistration(solve(1, 2), hopeless);
  EXPECT_GT(hopeless.cost_evaluations, unchecked.cost_evaluations);  // candidates were solved

  settings.mirror_check.continued_outer_iterations = -1;
  EXPECT_THROW_WITH(registration::Registrar(scene.bones, settings, {knee}),
                    "continued_outer_iterations >= 0");
}

// A view turned 7 deg about the leg: the tray is seen nearly edge-on but turned about its stem.
// Started with only its tilt on the wrong side of edge-on, the full mirror and the turn
// reflection of that start are each off by twice the turn; only the tilt reflection (its turn
// kept) leads back to the truth.
TEST(Registrar, MirrorCheckReversesTheTiltAloneOfATurnedTray) {
  sim::TrialSimulatorSettings s;
  s.motion.frames = 12;
  s.view_yaw_deg = 7.0;
  s.view_roll_deg = -3.0;
  const SingleViewFrame scene(s, 5, 3);
  const auto& bones = scene.bones;
  const auto& views = scene.views;
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const Pose camera_from_fixed = scene.cameraFromFixed();
  const std::vector<Pose> start = {
      truth[0], scene.camera().worldFromCamera() *
                    registration::tiltReflectedAcrossBeam(camera_from_fixed * truth[1])};
  registration::RegistrationSettings settings;
  settings.depth_retry.enabled = false;  // the mirror check alone
  settings.mirror_check.tilt_reflection = false;
  const registration::JointModel knee = kneeJoint();
  const auto without = registration::Registrar(bones, settings, {knee}).solve(views, start);
  ASSERT_FALSE(registration::meetsSuccessCriterion(
      registration::poseError(without.poses[1], truth[1], camera_from_fixed)))
      << "the full mirror or the turn reflection alone recovers this tray: the test shows nothing";
  settings.mirror_check.tilt_reflection = true;
  const auto with = registration::Registrar(bones, settings, {knee}).solve(views, start);
  for (int b = 0; b < 2; ++b) {
    const registration::PoseError e =
        registration::poseError(with.poses[b], truth[b], camera_from_fixed);
    EXPECT_TRUE(registration::meetsSuccessCriterion(e))
        << bones[b].name << ": rotation " << e.rotation_deg.transpose() << " deg";
  }
  // Two threads (the default) solve the three candidates side by side, each on maps of its own:
  // the same poses, cost and evaluations as one thread solving them in turn.
  ASSERT_EQ(settings.threads, 2);
  settings.threads = 1;
  const auto in_turn = registration::Registrar(bones, settings, {knee}).solve(views, start);
  expectSameRegistration(in_turn, with);
}

// Both bones start 20-26 mm too near the source and 3.4 deg off, from where the solve settles
// on the wrong size with the wrong tilts. The quality status says so, and the retry from the
// result moved along the beam finds the truth.
TEST(Registrar, DepthRetryRecoversAStartFarAlongTheBeam) {
  const Scene scene;
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const geometry::XrayCamera& camera = scene.camera();
  const Pose camera_from_fixed = camera.worldFromCamera().inverse();
  std::vector<Pose> start = truth;
  for (int b = 0; b < 2; ++b) {
    Pose in_camera = camera_from_fixed * truth[b];
    in_camera.translation().z() -= b == 0 ? 0.020 : 0.026;
    in_camera.linear() =
        geometry::rotationX(-0.06) * geometry::rotationY(0.06) * in_camera.linear();
    start[b] = camera.worldFromCamera() * in_camera;
  }
  registration::RegistrationSettings settings;
  settings.scales = {0.25, 0.5, 1.0};  // the crude protocol's schedule
  settings.depth_retry.enabled = false;
  const std::vector<registration::ViewImage> views = {{scene.frame.images[0], camera}};
  const auto single =
      registration::Registrar(scene.bones, settings, {kneeJoint()}).solve(views, start);
  const auto single_status = registration::classifyBones(single, settings.quality);
  ASSERT_NE(single_status, (std::vector<std::string>{"ok", "ok"}))
      << "the first solve must end flagged for the test to mean anything";
  ASSERT_FALSE(registration::meetsSuccessCriterion(
                   registration::poseError(single.poses[0], truth[0], camera_from_fixed)) &&
               registration::meetsSuccessCriterion(
                   registration::poseError(single.poses[1], truth[1], camera_from_fixed)));
  settings.depth_retry.enabled = true;
  const auto retried =
      registration::Registrar(scene.bones, settings, {kneeJoint()}).solve(views, start);
  EXPECT_EQ(registration::classifyBones(retried, settings.quality),
            (std::vector<std::string>{"ok", "ok"}));
  for (int b = 0; b < 2; ++b) {
    const registration::PoseError error =
        registration::poseError(retried.poses[b], truth[b], camera_from_fixed);
    EXPECT_TRUE(registration::meetsSuccessCriterion(error)) << scene.bones[b].name;
    EXPECT_LT(std::abs(error.translation_mm.z()), 5.0) << scene.bones[b].name;
  }
  // The retries' solves are counted.
  EXPECT_GT(retried.cost_evaluations, single.cost_evaluations);
  // Solved side by side (threads: 2, the default) or in turn, the retries give the same result.
  settings.threads = 1;
  const auto in_turn =
      registration::Registrar(scene.bones, settings, {kneeJoint()}).solve(views, start);
  expectSameRegistration(in_turn, retried);
}

// The light depth retry (DepthRetrySettings::light_below_inlier_fraction): on poor frames (768 x
// 768, a quarter of the dose, a metal rod) registered from their true poses every bone ends ok,
// but short of the edges; solved again from the shifts on the finest maps, the better ranked
// result (more contour inliers) is kept, the same on one thread or two.
TEST(Registrar, LightDepthRetryKeepsTheBetterRankedOfAResultInDoubt) {
  sim::TrialSimulatorSettings poor;
  poor.motion.frames = 12;
  poor.pixel_spacing_mm *= poor.image_width / 768.0;
  poor.image_width = 768;
  poor.image_height = 768;
  poor.detector.photons_per_pixel /= 4.0;
  poor.occluder_rod_radius_mm = 2.5;
  registration::RegistrationSettings settings;
  const auto inliers = [](const registration::RegistrationResult& r) {
    return r.quality[0].contour_inlier_fraction + r.quality[1].contour_inlier_fraction;
  };
  int replaced = 0;
  for (int index : {2, 5}) {
    const SingleViewFrame scene(poor, index, 3);
    const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
    const auto solve = [&](double light, int threads) {
      settings.depth_retry.light_below_inlier_fraction = light;
      settings.threads = threads;
      return registration::Registrar(scene.bones, settings, {kneeJoint()})
          .solve(scene.views, truth);
    };
    const auto without = solve(0.0, 2);
    ASSERT_EQ(registration::classifyBones(without, settings.quality),
              (std::vector<std::string>{"ok", "ok"}))
        << "frame " << index;
    ASSERT_LT(inliers(without), 2.0) << "frame " << index << " is not in doubt";
    const auto with = solve(1.0, 2);
    EXPECT_GT(with.cost_evaluations, without.cost_evaluations) << "frame " << index;
    EXPECT_GE(inliers(with), inliers(without)) << "frame " << index;
    EXPECT_EQ(registration::classifyBones(with, settings.quality),
              (std::vector<std::string>{"ok", "ok"}));
    replaced += with.poses[1].isApprox(without.poses[1], 0.0) ? 0 : 1;
    const auto in_turn = solve(1.0, 1);
    expectSameRegistration(in_turn, with);
  }
  EXPECT_GT(replaced, 0) << "no retry was kept: the test shows only that they run";
  settings.depth_retry.light_below_inlier_fraction = -0.1;
  EXPECT_THROW_WITH(settings.validate(), "light_below_inlier_fraction must be in [0, 1]");
}

TEST(MirrorAmbiguity, MirrorKeepsTheSilhouetteOfASymmetricMeshAndNeutralIsMeasuredInBounds) {
  const Pose camera_from_mesh = geometry::makePose(
      geometry::rotationY(0.3) * geometry::rotationX(-0.2), Eigen::Vector3d(0.01, -0.02, 0.9));
  const Pose mirrored = registration::mirroredAcrossBeam(camera_from_mesh);
  EXPECT_LT(geometry::rotationAngleBetween(registration::mirroredAcrossBeam(mirrored).linear(),
                                           camera_from_mesh.linear()),
            1e-12);
  EXPECT_LT((mirrored.translation() - camera_from_mesh.translation()).norm(), 1e-15);
  EXPECT_GT(geometry::rotationAngleBetween(mirrored.linear(), camera_from_mesh.linear()), 0.1);
  // A point and its reflection through the mesh's X-Y plane swap places, seen along the beam.
  const Eigen::Vector3d p(0.03, 0.01, 0.02);
  const Eigen::Vector3d reflected(p.x(), p.y(), -p.z());
  EXPECT_LT(((mirrored * reflected).head<2>() - (camera_from_mesh * p).head<2>()).norm(), 1e-15);

  // The turn reflection keeps the long axis and the position, reverses the medial-lateral
  // axis's turn about it relative to the beam, and undoes itself.
  const Pose turned = registration::turnReflectedAcrossBeam(camera_from_mesh);
  const Eigen::Vector3d axis = camera_from_mesh.linear().col(1);
  EXPECT_LT((turned.linear().col(1) - axis).norm(), 1e-12);
  EXPECT_LT((turned.translation() - camera_from_mesh.translation()).norm(), 1e-15);
  const Eigen::Vector3d normal =
      axis.cross(Eigen::Vector3d::UnitZ() - axis.z() * axis).normalized();
  EXPECT_NEAR(turned.linear().col(2).dot(normal), -camera_from_mesh.linear().col(2).dot(normal),
              1e-12);
  EXPECT_GT(std::abs(camera_from_mesh.linear().col(2).dot(normal)), 0.05);
  EXPECT_LT(geometry::rotationAngleBetween(registration::turnReflectedAcrossBeam(turned).linear(),
                                           camera_from_mesh.linear()),
            1e-9);

  // The tilt reflection is the mirror with the turn kept: reflecting its turn gives the full
  // mirror, and it undoes itself.
  const Pose tilted = registration::tiltReflectedAcrossBeam(camera_from_mesh);
  EXPECT_LT(geometry::rotationAngleBetween(registration::turnReflectedAcrossBeam(tilted).linear(),
                                           mirrored.linear()),
            1e-9);
  EXPECT_LT(geometry::rotationAngleBetween(registration::tiltReflectedAcrossBeam(tilted).linear(),
                                           camera_from_mesh.linear()),
            1e-9);
  EXPECT_GT(geometry::rotationAngleBetween(tilted.linear(), mirrored.linear()), 0.05);
  EXPECT_GT(geometry::rotationAngleBetween(tilted.linear(), camera_from_mesh.linear()), 0.05);

  constraints::LigamentSettings ligaments;  // adduction +-3 deg, internal rotation +-20 deg
  kinematics::KneeCoordinates k;
  k.adduction_rad = geometry::degToRad(1.5);
  k.internal_rotation_rad = geometry::degToRad(-10.0);
  k.flexion_rad = geometry::degToRad(90.0);  // no part of the measure with neutral at 0 deg
  EXPECT_NEAR(registration::neutralDeviation(ligaments, k), 0.5 + 0.5, 1e-12);
  // Neutral internal rotation 0.05 deg per degree of flexion: 4.5 deg at 90 deg, so -10 deg is
  // 14.5 deg from it and 4.5 deg is neutral; none in hyperextension.
  EXPECT_NEAR(registration::neutralDeviation(ligaments, k, 0.05), 0.5 + 14.5 / 20.0, 1e-12);
  k.internal_rotation_rad = geometry::degToRad(4.5);
  EXPECT_NEAR(registration::neutralDeviation(ligaments, k, 0.05), 0.5, 1e-12);
  k.flexion_rad = geometry::degToRad(-5.0);
  EXPECT_NEAR(registration::neutralDeviation(ligaments, k, 0.05), 0.5 + 4.5 / 20.0, 1e-12);
  k.internal_rotation_rad = geometry::degToRad(-10.0);
  ligaments.bounds[2] = {-10.0, 30.0};  // the bound on the value's side is the unit
  EXPECT_NEAR(registration::neutralDeviation(ligaments, k), 0.5 + 1.0, 1e-12);
}

// Deep flexion (94 deg) with the tibia turned 8 deg internally, as the simulator's knee turns
// (the benchmark's seed 3, trial 0, frame 12: its flexion range and view). Registered from the
// truth, the tray's turn reflection fits about as well at about -2 deg; with neutral at 0 deg
// whatever the flexion, the mirror check takes it, nearer 0; with neutral turning with flexion
// (the default), the truth stays.
TEST(Registrar, MirrorCheckKeepsATibiaTurnedAsTheKneeFlexes) {
  sim::TrialSimulatorSettings s;
  s.motion.frames = 25;
  s.motion.max_flexion_deg = 93.5;
  s.view_yaw_deg = -4.87;
  s.view_roll_deg = 0.9;
  s.seed = 3;
  const SingleViewFrame scene(s, 12, 3);
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  const Pose camera_from_fixed = scene.cameraFromFixed();
  const registration::JointModel knee = kneeJoint();
  const kinematics::KneeCoordinates true_knee = knee.coordinates(truth[0], truth[1]);
  ASSERT_GT(geometry::radToDeg(true_knee.flexion_rad), 80.0);
  ASSERT_GT(geometry::radToDeg(true_knee.internal_rotation_rad), 6.0);
  registration::RegistrationSettings settings;
  settings.mirror_check.neutral_internal_rotation_per_flexion = 0.0;
  const auto at_zero =
      registration::Registrar(scene.bones, settings, {knee}).solve(scene.views, truth);
  ASSERT_FALSE(registration::meetsSuccessCriterion(
      registration::poseError(at_zero.poses[1], truth[1], camera_from_fixed)))
      << "with neutral at 0 deg the check must take the turn reflection for the test to mean "
         "anything";
  settings.mirror_check.neutral_internal_rotation_per_flexion =
      registration::MirrorCheckSettings().neutral_internal_rotation_per_flexion;
  ASSERT_GT(settings.mirror_check.neutral_internal_rotation_per_flexion, 0.0);
  const auto turning =
      registration::Registrar(scene.bones, settings, {knee}).solve(scene.views, truth);
  for (int b = 0; b < 2; ++b) {
    const registration::PoseError e =
        registration::poseError(turning.poses[b], truth[b], camera_from_fixed);
    EXPECT_TRUE(registration::meetsSuccessCriterion(e))
        << scene.bones[b].name << ": rotation " << e.rotation_deg.transpose() << " deg";
  }
}

TEST(Registrar, JointsMustNameTwoBonesOfTheRegistrar) {
  const Scene scene;
  registration::JointModel knee = kneeJoint();
  knee.child = 2;
  EXPECT_THROW_WITH(
      registration::Registrar(scene.bones, registration::RegistrationSettings(), {knee}),
      "two different bones");
  knee.child = 0;
  EXPECT_THROW_WITH(
      registration::Registrar(scene.bones, registration::RegistrationSettings(), {knee}),
      "two different bones");
}

TEST(Registrar, ContourMetricIsSmallestNearTheTruthAndGrowsWithOffset) {
  const Scene scene;
  const auto& camera = scene.camera();
  const imaging::EdgeMap map(scene.frame.images[0], camera, imaging::EdgeMapSettings());
  const auto cost_at = [&](double dx) {
    const Pose pose = offset(scene.frame.femur, {dx, 0.0, 0.0}, Eigen::Vector3d::Zero());
    const auto contour = scene.bones[0].silhouette->contour(map.camera(), pose, 1.0);
    std::vector<Eigen::Vector3d> points;
    std::vector<Eigen::Vector2d> offset_directions;
    for (const auto& c : contour) {
      points.push_back(pose * c.model_point);
      offset_directions.push_back(-c.normal);
    }
    const registration::ContourDistanceCost cost(&map, points, offset_directions,
                                                 pose.translation(), 4.0, 1.0);
    const double zero[6] = {0, 0, 0, 0, 0, 0};
    const double no_offset = 0.0;
    const double* parameters[2] = {zero, &no_offset};
    std::vector<double> residuals(points.size());
    cost.Evaluate(parameters, residuals.data(), nullptr);
    double sum = 0.0;
    for (double r : residuals) sum += r * r;
    return sum / residuals.size();
  };
  const double at_truth = cost_at(0.0);
  EXPECT_LT(at_truth, cost_at(0.0005));
  EXPECT_LT(cost_at(0.0005), cost_at(0.0015));
  EXPECT_LT(at_truth, cost_at(-0.001));
  EXPECT_LT(cost_at(-0.001), cost_at(-0.003));
}

// The tray's contour term on the scene's frame, 0.8 mm off its true pose, every 4 px.
struct TrayContourTerm {
  Scene scene;
  imaging::EdgeMap map{scene.frame.images[0], scene.camera(), imaging::EdgeMapSettings()};
  Pose pose = offset(scene.frame.tibia, {0.0008, 0.0, 0.0}, Eigen::Vector3d::Zero());
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> offset_directions;  // inward, as the uniform offset model's
  std::vector<Eigen::Vector2d> normals;            // outward

  TrayContourTerm() {
    for (const auto& c : scene.bones[1].silhouette->contour(map.camera(), pose, 4.0)) {
      points.push_back(pose * c.model_point);
      offset_directions.push_back(-c.normal);
      normals.push_back(c.normal);
    }
  }
  registration::ContourDistanceCost cost(std::vector<Eigen::Vector2d> shifts = {}) const {
    return registration::ContourDistanceCost(&map, points, offset_directions, pose.translation(),
                                             4.0, 2.0, std::move(shifts));
  }
};

// The contour term's fixed per-sample shifts (corner rounding) move each sample as the edge
// offset does: shifts of 0.3 px along the offset directions give the residuals of an offset of
// 0.3 px.
TEST(Registrar, ContourTermShiftsMoveSamplesAsTheOffsetDoes) {
  const TrayContourTerm term;
  std::vector<Eigen::Vector2d> shifts;
  for (const auto& n : term.normals) shifts.push_back(-0.3 * n);
  const auto shifted = term.cost(shifts);
  const auto plain = term.cost();
  const double x[6] = {0.01, -0.02, 0.015, 0.0003, -0.0002, 0.0004};
  const double none = 0.0;
  const double some = 0.3;
  const double* at_none[2] = {x, &none};
  const double* at_some[2] = {x, &some};
  std::vector<double> a(term.points.size());
  std::vector<double> b(term.points.size());
  ASSERT_TRUE(shifted.Evaluate(at_none, a.data(), nullptr));
  ASSERT_TRUE(plain.Evaluate(at_some, b.data(), nullptr));
  int moved = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(a[i], b[i], 1e-9) << "sample " << i;
    moved += a[i] != 0.0;
  }
  EXPECT_GT(moved, 0);
}

TEST(Registrar, AnalyticJacobianMatchesFiniteDifferences) {
  const TrayContourTerm term;
  const auto cost = term.cost();
  const double x[6] = {0.01, -0.02, 0.015, 0.0003, -0.0002, 0.0004};
  const double edge_offset = 0.3;
  const double* parameters[2] = {x, &edge_offset};
  const std::size_t n = term.points.size();
  std::vector<double> r0(n);
  std::vector<double> jac(6 * n);
  std::vector<double> jac_offset(n);
  double* jacobians[2] = {jac.data(), jac_offset.data()};
  ASSERT_TRUE(cost.Evaluate(parameters, r0.data(), jacobians));
  int compared = 0;
  int agreeing = 0;
  for (int k = 0; k < 6; ++k) {
    const double h = k < 3 ? 1e-6 : 1e-8;
    double xp[6];
    double xm[6];
    std::copy(x, x + 6, xp);
    std::copy(x, x + 6, xm);
    xp[k] += h;
    xm[k] -= h;
    std::vector<double> rp(n);
    std::vector<double> rm(n);
    const double* pp[2] = {xp, &edge_offset};
    const double* pm[2] = {xm, &edge_offset};
    cost.Evaluate(pp, rp.data(), nullptr);
    cost.Evaluate(pm, rm.data(), nullptr);
    for (std::size_t i = 0; i < n; ++i) {
      const double numeric = (rp[i] - rm[i]) / (2 * h);
      const double analytic = jac[6 * i + k];
      if (std::abs(numeric) < 1e-3 && std::abs(analytic) < 1e-3) continue;
      ++compared;
      // The distance map is piecewise bilinear: samples straddling a cell border differ.
      if (std::abs(numeric - analytic) <=
          0.1 * std::max(std::abs(numeric), std::abs(analytic)) + 1e-3)
        ++agreeing;
    }
  }
  ASSERT_GT(compared, 100);
  EXPECT_GT(agreeing, 0.9 * compared);
  // The edge offset's column.
  const double offset_plus = edge_offset + 1e-4;
  const double offset_minus = edge_offset - 1e-4;
  std::vector<double> rp(n);
  std::vector<double> rm(n);
  const double* pp[2] = {x, &offset_plus};
  const double* pm[2] = {x, &offset_minus};
  cost.Evaluate(pp, rp.data(), nullptr);
  cost.Evaluate(pm, rm.data(), nullptr);
  int offset_compared = 0;
  int offset_agreeing = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double numeric = (rp[i] - rm[i]) / 2e-4;
    if (std::abs(numeric) < 1e-3 && std::abs(jac_offset[i]) < 1e-3) continue;
    ++offset_compared;
    if (std::abs(numeric - jac_offset[i]) <= 0.1 * std::abs(numeric) + 1e-3) ++offset_agreeing;
  }
  ASSERT_GT(offset_compared, 20);
  EXPECT_GT(offset_agreeing, 0.9 * offset_compared);
  // The cost alone, then with Jacobians at the same parameters (Ceres' order after an accepted
  // step: the second reuses the first's samples), gives what the first evaluation gave.
  std::vector<double> r1(n);
  std::vector<double> jac1(6 * n);
  std::vector<double> jac_offset1(n);
  double* jacobians1[2] = {jac1.data(), jac_offset1.data()};
  ASSERT_TRUE(cost.Evaluate(parameters, r1.data(), nullptr));
  EXPECT_EQ(r1, r0);
  ASSERT_TRUE(cost.Evaluate(parameters, r1.data(), jacobians1));
  EXPECT_EQ(r1, r0);
  EXPECT_EQ(jac1, jac);
  EXPECT_EQ(jac_offset1, jac_offset);
}

TEST(Registrar, PoseIncrementRotatesAboutTheCentre) {
  const Pose pose = geometry::makePose(geometry::rotationZ(0.3), Eigen::Vector3d(1.0, 2.0, 3.0));
  const Eigen::Vector3d centre(1.0, 2.0, 3.5);
  const double increment[6] = {0.0, 0.0, 0.2, 0.01, 0.0, 0.0};
  const Pose moved = registration::applyIncrement(pose, centre, increment);
  // The centre only moves by the translation part.
  const Eigen::Vector3d centre_in_bone = pose.inverse() * centre;
  EXPECT_TRUE((moved * centre_in_bone).isApprox(centre + Eigen::Vector3d(0.01, 0, 0), 1e-12));
  EXPECT_NEAR(geometry::rotationAngleBetween(pose.linear(), moved.linear()), 0.2, 1e-12);
}

TEST(Registrar, BadInputsNameTheProblem) {
  const Scene scene;
  const registration::Registrar registrar(scene.bones, registration::RegistrationSettings());
  const auto& camera = scene.camera();
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  EXPECT_THROW_WITH(registrar.solve({}, truth), "no views");
  EXPECT_THROW_WITH(registrar.solve({{scene.frame.images[0], camera}}, {truth[0]}),
                    "1 pose(s) for 2 bone(s)");
  EXPECT_THROW_WITH(registrar.solve({{cv::Mat(), camera}}, truth), "is empty");
  cv::Mat small;
  cv::resize(scene.frame.images[0], small, cv::Size(512, 512));
  EXPECT_THROW_WITH(registrar.solve({{small, camera}}, truth), "camera_info says 1024x1024");
  Pose behind = truth[0];
  behind.translation().z() = -1.0;
  EXPECT_THROW_WITH(registrar.solve({{scene.frame.images[0], camera}}, {behind, truth[1]}),
                    "behind the X-ray source");
  Pose nan_pose = truth[0];
  nan_pose.translation().x() = std::nan("");
  EXPECT_THROW_WITH(registrar.solve({{scene.frame.images[0], camera}}, {nan_pose, truth[1]}),
                    "not a finite");
}

TEST(PoseError, MeasuresInTheViewAndAboutTheBoneAxesAndAppliesTheCriterion) {
  const Pose truth = geometry::makePose(geometry::rotationZ(0.4), Eigen::Vector3d(0.01, 0.02, 1.0));
  // A view turned a quarter turn about its y axis: fixed x is the view's -z (along the beam).
  const Pose camera_from_fixed =
      geometry::makePose(geometry::rotationY(M_PI / 2), Eigen::Vector3d::Zero());
  Pose estimate = truth;
  estimate.translation() += Eigen::Vector3d(0.002, 0.0005, 0.0);
  estimate.linear() = truth.linear() * geometry::rotationY(geometry::degToRad(2.5));
  const auto e = registration::poseError(estimate, truth, camera_from_fixed);
  EXPECT_TRUE(e.translation_mm.isApprox(Eigen::Vector3d(0.0, 0.5, -2.0), 1e-9));
  EXPECT_TRUE(e.rotation_deg.isApprox(Eigen::Vector3d(0.0, 2.5, 0.0), 1e-9));
  EXPECT_TRUE(registration::meetsSuccessCriterion(e));  // 2 mm along the beam, 2.5 deg about Y
  auto worse = e;
  worse.rotation_deg.y() = 3.1;
  EXPECT_FALSE(registration::meetsSuccessCriterion(worse));
  worse = e;
  worse.rotation_deg.x() = 2.1;
  EXPECT_FALSE(registration::meetsSuccessCriterion(worse));
  worse = e;
  worse.translation_mm.x() = -1.1;
  EXPECT_FALSE(registration::meetsSuccessCriterion(worse));
}

// Frames succeed when every bone does; RMS is over bone-frames.
TEST(PoseError, AccuracyTallyCountsFramesAndRms) {
  registration::AccuracyTally tally;
  registration::PoseError good{Eigen::Vector3d(0.5, -0.5, 3.0), Eigen::Vector3d(1.0, 2.0, -1.0)};
  registration::PoseError off{Eigen::Vector3d(1.5, 0.0, 0.0), Eigen::Vector3d::Zero()};
  tally.addFrame({good, good});
  tally.addFrame({good, off});
  EXPECT_EQ(tally.frames(), 2);
  EXPECT_EQ(tally.framesWithin(), 1);
  EXPECT_NEAR(tally.rms()[0], std::sqrt((3 * 0.25 + 2.25) / 4.0), 1e-12);
  EXPECT_NEAR(tally.rms()[2], std::sqrt(3 * 9.0 / 4.0), 1e-12);
  EXPECT_NE(tally.summary().find("1/2 frames within 1 mm"), std::string::npos) << tally.summary();
  registration::AccuracyTally loose(registration::kChapter4Criterion);
  loose.addFrame({good, off});
  EXPECT_EQ(loose.framesWithin(), 1);
}

// The real JointTrack Kneel frames, each registered from the lab's reference poses perturbed as
// in the dissertation's protocol (+-2 mm in-plane, +-3 mm along the beam, +-3 deg), with the
// knee's envelope (flexion free: these meshes' medial-lateral axes point the other way; no
// insert, so no contact). From full resolution alone the tibial tray slid 10-30 mm along the
// beam from some of these starts while its edge offset was held at zero; the default
// half-resolution pass keeps it in place.
TEST(Registrar, RecoversTheRealKneelPosesFromPerturbedStarts) {
  const test_support::KneelStudy kneel;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const auto& frame : kneel.frames) {
    ASSERT_FALSE(frame.image.empty()) << frame.name;
    for (int start = 0; start < 6; ++start) {
      std::vector<Pose> starts;
      for (const Pose& r : frame.reference) {
        double draws[6];
        for (double& d : draws) d = unit(rng);  // in a fixed order
        starts.push_back(
            offset(r, Eigen::Vector3d(0.002 * draws[0], 0.002 * draws[1], 0.003 * draws[2]),
                   geometry::degToRad(3.0) * Eigen::Vector3d(draws[3], draws[4], draws[5])));
      }
      const auto result = kneel.registrar->solve({{frame.image, frame.camera}}, starts);
      for (int b = 0; b < 2; ++b) {
        const auto e =
            registration::poseError(result.poses[b], frame.reference[b], Pose::Identity());
        EXPECT_LT(std::hypot(e.translation_mm.x(), e.translation_mm.y()), 1.0)
            << "frame " << frame.name << " start " << start << " bone " << b;
        EXPECT_LT(e.rotation_deg.norm(), 2.0)
            << "frame " << frame.name << " start " << start << " bone " << b;
      }
    }
  }
}

// Image only, the real Kneel tray started 3 deg to the wrong side about its anterior axis and
// 3 deg about its long axis converges to its tilt reflection's false minimum: 4-6 deg off and
// 5-25 mm along the beam, its contour on the edges at 0.63-0.81 against 0.89-0.94 at the
// reference. The reflection retry (ReflectionRetrySettings) solves again from the tray's
// reflections across the beam and keeps the better fit nearest the start. From the second start
// on frame 0160 the tray's turn reflection, 32 deg about its stem, fits about as well as its tilt
// reflection (0.883 against 0.879 of the contour on edges): the start decides between them.
TEST(Registrar, ReflectionRetryFreesTheRealKneelTrayFromItsTiltReflection) {
  const test_support::KneelStudy kneel;
  registration::RegistrationSettings settings;
  settings.rotation_retry.enabled = false;  // the reflection retry alone (it frees 0160's too)
  settings.reflection_retry.enabled = false;
  const registration::Registrar without(kneel.registrar->bones(), settings);
  settings.reflection_retry.enabled = true;
  const registration::Registrar with(kneel.registrar->bones(), settings);
  // Frames 0160 and 0170, each from two starts: (shift along the beam, rotation about X and Y).
  const std::array<std::pair<double, Eigen::Vector3d>, 2> tray_offsets = {
      std::make_pair(0.003, Eigen::Vector3d(-1.0, -1.0, 0.0)),
      std::make_pair(-0.003, Eigen::Vector3d(-1.0, 1.0, 0.0))};
  for (std::size_t k = 0; k < 4; ++k) {
    const auto& frame = kneel.frames[k / 2];
    const auto& [shift_m, rotation_axes] = tray_offsets[k % 2];
    SCOPED_TRACE("frame " + frame.name + ", start " + std::to_string(k % 2));
    ASSERT_FALSE(frame.image.empty()) << frame.name;
    const std::vector<Pose> starts = {frame.reference[0],
                                      offset(frame.reference[1], Eigen::Vector3d(0.0, 0.0, shift_m),
                                             geometry::degToRad(3.0) * rotation_axes)};
    const std::vector<registration::ViewImage> views = {{frame.image, frame.camera}};
    const auto trapped = without.solve(views, starts);
    const auto trapped_error =
        registration::poseError(trapped.poses[1], frame.reference[1], Pose::Identity());
    ASSERT_GT(trapped_error.rotation_deg.norm(), 3.0)
        << "frame " << frame.name << ": the start must trap the tray for the test to mean anything";
    const auto freed = with.solve(views, starts);
    for (int b = 0; b < 2; ++b) {
      const auto e = registration::poseError(freed.poses[b], frame.reference[b], Pose::Identity());
      EXPECT_LT(std::hypot(e.translation_mm.x(), e.translation_mm.y()), 1.0)
          << "frame " << frame.name << " bone " << b;
      EXPECT_LT(e.rotation_deg.norm(), 2.0) << "frame " << frame.name << " bone " << b;
    }
    // Back from the false minimum along the beam too (the femoral component, never trapped,
    // lies 5-8 mm from the lab's reference along the beam in every registration).
    EXPECT_LT(std::abs(registration::poseError(freed.poses[1], frame.reference[1], Pose::Identity())
                           .translation_mm.z()),
              5.0)
        << frame.name;
    EXPECT_GT(
        freed.quality[1].contour_inlier_fraction,
        trapped.quality[1].contour_inlier_fraction + settings.reflection_retry.min_inlier_gain)
        << frame.name;
    // The retry's solves are counted.
    EXPECT_GT(freed.cost_evaluations, trapped.cost_evaluations) << frame.name;
    if (k == 0) {
      // The reflections solved side by side (threads: 2, the default) or in turn: the same.
      registration::RegistrationSettings one_thread = settings;
      one_thread.threads = 1;
      const auto in_turn =
          registration::Registrar(kneel.registrar->bones(), one_thread).solve(views, starts);
      expectSameRegistration(in_turn, freed);
    }
  }
}

// Trial 2 of the standard protocol's seed 3 (`benchmark --seed 3`: flexion to 81.5 deg, the view
// turned -6.3 deg and rolled -1.6 deg): started from the truth with the tray turned 3 deg one way
// about its own medial-lateral axis, every frame ends in a false minimum a few degrees off and
// millimetres along the beam, at several times the cost it reaches from the truth, its contour
// spread wide about its edges. The rotation retry (RotationRetrySettings) solves again from the
// result turned either way about each of the bone's axes and keeps the lowest cost.
TEST(Registrar, RotationRetryLeavesAFalseMinimumAFewDegreesOff) {
  sim::TrialSimulatorSettings s;
  s.motion.frames = 25;
  s.motion.max_flexion_deg = 81.544930361876936;
  s.view_yaw_deg = -6.2524165979262643;
  s.view_roll_deg = -1.6452624147092569;
  s.seed = 5;
  const SingleViewFrame scene(s, 19, 5);
  const Pose camera_from_fixed = scene.cameraFromFixed();
  const std::vector<Pose> truth = {scene.frame.femur, scene.frame.tibia};
  std::vector<Pose> start = truth;
  start[1].linear() = truth[1].linear() * geometry::rotationX(geometry::degToRad(-3.0));
  registration::RegistrationSettings settings;
  settings.rotation_retry.enabled = false;
  const auto trapped =
      test_support::simulatedKneeRegistrar(scene.simulator, settings)->solve(scene.views, start);
  const auto trapped_error = registration::poseError(trapped.poses[1], truth[1], camera_from_fixed);
  ASSERT_FALSE(registration::meetsSuccessCriterion(trapped_error))
      << "the start must trap the tray for the test to mean anything";
  ASSERT_GT(trapped.quality[1].contour_spread_px,
            registration::RotationRetrySettings().above_contour_spread_px);
  settings.rotation_retry.enabled = true;
  const auto freed =
      test_support::simulatedKneeRegistrar(scene.simulator, settings)->solve(scene.views, start);
  for (std::size_t b = 0; b < 2; ++b) {
    EXPECT_TRUE(registration::meetsSuccessCriterion(
        registration::poseError(freed.poses[b], truth[b], camera_from_fixed)))
        << "bone " << b;
  }
  EXPECT_LT(freed.final_cost, trapped.final_cost);
  EXPECT_GT(freed.cost_evaluations, trapped.cost_evaluations);
}

// Frame 0 of the `video_512` robustness variant (512 x 512 over the standard field), registered
// from its true pose with the trial's own knee (contact on the insert, ligaments): the first
// solve leaves the femoral component on a false fit (0.83 of its outline on edges), the knee
// 2 deg in adduction. The mirror check then turns the tray about its stem to fit that femur
// better and nearer neutral, which lifts the femur's inliers above the reflection retry's gate:
// without ReflectionRetrySettings::before_mirror_check the tray ends 6.6 deg off. With it the
// femur is retried from the first solution's reflections, and the truth fits at a lower cost.
TEST(Registrar, ReflectionRetryAlsoFreesAFemurTheMirrorCheckHid) {
  test_support::TempDir dir;
  const sim::TrialSimulatorSettings s = sim::loadSimulatorSettings(
      std::string(FLUORO_SOURCE_DIR) + "/config/robustness/video_512.yaml");
  const sim::TrialSimulator simulator(s);
  simulator.writeModels(dir.file("models"));
  const io::TrialConfig config = simulator.trialConfig(dir.file("models"));
  const io::TrialModels models = io::loadTrialModels(config);
  std::mt19937_64 rng(s.seed);  // as simulate_trial renders frame 0
  const sim::SimulatedFrame frame = simulator.render(0, &rng);
  const geometry::XrayCamera& camera = simulator.views()[0].camera;
  const Pose camera_from_fixed = camera.worldFromCamera().inverse();
  const std::vector<registration::ViewImage> views = {{frame.images[0], camera}};
  const std::vector<Pose> truth = {frame.femur, frame.tibia};
  registration::RegistrationSettings settings = config.registration;
  ASSERT_TRUE(settings.reflection_retry.before_mirror_check) << "the default";
  settings.reflection_retry.before_mirror_check = false;
  const auto hidden =
      registration::Registrar(models.bones, settings, models.joints).solve(views, truth);
  ASSERT_FALSE(registration::meetsSuccessCriterion(
      registration::poseError(hidden.poses[1], frame.tibia, camera_from_fixed)))
      << "the tray must end on its turn reflection for the test to mean anything";
  settings.reflection_retry.before_mirror_check = true;
  const auto freed =
      registration::Registrar(models.bones, settings, models.joints).solve(views, truth);
  for (std::size_t b = 0; b < 2; ++b) {
    EXPECT_TRUE(registration::meetsSuccessCriterion(
        registration::poseError(freed.poses[b], truth[b], camera_from_fixed)))
        << "bone " << b;
  }
  EXPECT_LT(freed.final_cost, hidden.final_cost);
  EXPECT_GT(freed.quality[0].contour_inlier_fraction, 0.95);
  EXPECT_GT(freed.cost_evaluations, hidden.cost_evaluations);
}

// Bi-plane crude starts (the benchmark's: each bone up to 20 or 50 mm along the first beam):
// here the femoral component 15 mm away from the source and the tray 45 mm towards it. The
// second view sees them tens of pixels off their outlines, beyond what a registration or the
// depth retry's fixed shifts reach, and the femoral component ends lost. The retry first moves a
// bone in doubt by its own contour's shift to the views' edges
// (DepthRetrySettings::other_views_shift_mm).
TEST(Registrar, DepthRetryMovesABoneInDoubtToWhereTheOtherViewSeesIt) {
  sim::TrialSimulatorSettings bi_plane = Scene::settings();
  bi_plane.views = 2;
  const sim::TrialSimulator simulator(bi_plane);
  std::mt19937_64 rng(3);
  const sim::SimulatedFrame frame = simulator.render(5, &rng);
  const std::vector<registration::ViewImage> views = {
      {frame.images[0], simulator.views()[0].camera},
      {frame.images[1], simulator.views()[1].camera}};
  const geometry::XrayCamera& first = simulator.views()[0].camera;
  const Pose camera_from_fixed = first.worldFromCamera().inverse();
  const std::vector<Pose> truth = {frame.femur, frame.tibia};
  std::vector<Pose> start = truth;
  const double along_beam_m[2] = {0.015, -0.045};
  for (int b = 0; b < 2; ++b) {
    Pose in_camera = camera_from_fixed * truth[b];
    in_camera.translation().z() += along_beam_m[b];
    start[b] = first.worldFromCamera() * in_camera;
  }
  registration::RegistrationSettings settings;
  settings.scales = {0.25, 0.5, 1.0};  // the crude protocol's schedule
  for (const double reach_mm : {0.0, settings.depth_retry.other_views_shift_mm}) {
    SCOPED_TRACE(reach_mm);
    settings.depth_retry.other_views_shift_mm = reach_mm;
    const auto result =
        test_support::simulatedKneeRegistrar(simulator, settings)->solve(views, start);
    const std::vector<std::string> status = registration::classifyBones(result, settings.quality);
    if (reach_mm > 0.0) {
      EXPECT_EQ(status, (std::vector<std::string>{"ok", "ok"}));
      for (int b = 0; b < 2; ++b) {
        const registration::PoseError error =
            registration::poseError(result.poses[b], truth[b], camera_from_fixed);
        EXPECT_TRUE(registration::meetsSuccessCriterion(error)) << b;
        EXPECT_LT(std::abs(error.translation_mm.z()), 1.0) << b;
      }
    } else {
      EXPECT_NE(status, (std::vector<std::string>{"ok", "ok"}))
          << "the registration and the fixed shifts now find both bones: the test needs a harder "
             "start";
    }
  }
}

// Contour samples inside the other bone's silhouette (the tray crossing the femoral component
// in flexion, where the two implants' edges fade) are left out of the inlier fraction, so the
// fraction of a registration at the truth stays high through the overlap.
TEST(Registrar, QualityLeavesOutContourCoveredByTheOtherBone) {
  sim::TrialSimulatorSettings settings;
  settings.motion.frames = 12;
  settings.motion.max_flexion_deg = 110.0;
  settings.views = 2;  // the second beam, 55 deg off lateral, sees the tray cross the femur
  const sim::TrialSimulator simulator(settings);
  // Where the two parts' metal overlaps, the simulator's window clips it, and the contour there
  // beside clipped grey is left out before the quality counts it (EdgeMapSettings::
  // clipped_grey_margin); without that the covered contour is what this test counts.
  registration::RegistrationSettings registration_settings;
  registration_settings.edges.clipped_grey_margin = 0.0;
  const auto registrar = test_support::simulatedKneeRegistrar(simulator, registration_settings);
  std::mt19937_64 rng(5);
  int overlapping = 0;
  for (int f : {0, 6}) {
    const sim::SimulatedFrame frame = simulator.render(f, &rng);
    const auto result = registrar->solve({{frame.images[0], simulator.views()[0].camera},
                                          {frame.images[1], simulator.views()[1].camera}},
                                         {frame.femur, frame.tibia});
    ASSERT_EQ(result.quality.size(), 2u);
    for (int b = 0; b < 2; ++b) {
      const auto& q = result.quality[b];
      SCOPED_TRACE("frame " + std::to_string(f) + " bone " + std::to_string(b));
      EXPECT_GT(q.contour_points, 0);
      EXPECT_GE(q.contour_inlier_fraction, 0.9) << q.covered_points << " covered";
      if (f == 0) {
        EXPECT_EQ(q.covered_points, 0);  // extended: the insert keeps them apart
      }
      if (q.covered_points > 0.05 * (q.contour_points + q.covered_points)) ++overlapping;
    }
  }
  // Otherwise the test shows nothing: in deep flexion the silhouettes overlap.
  EXPECT_GE(overlapping, 1);
}

// A displayed rim lies off the silhouette by an amount that depends on the material and the
// display (the edge offset the registrar estimates per bone). Bright titanium components,
// registered from the truth, fit well but their inliers' edge distances centre on that offset,
// so their RMS reads 0.6-0.9 px (the tray's about its offset) where their spread about its
// mean, which the suspect test reads, stays that of a good fit, 0.25-0.45 px (README "Tracking
// quality": the RMS test flagged such frames).
TEST(Registrar, ContourSpreadLeavesOutTheRimsUniformOffset) {
  sim::TrialSimulatorSettings settings;
  settings.motion.frames = 12;
  settings.femoral_material = "titanium";
  settings.tray_material = "titanium";
  settings.detector.implants_bright = true;
  const sim::TrialSimulator simulator(settings);
  const auto registrar = test_support::simulatedKneeRegistrar(simulator);
  std::mt19937_64 rng(3);
  const registration::QualitySettings thresholds;
  for (int f : {2, 6}) {
    const sim::SimulatedFrame frame = simulator.render(f, &rng);
    const auto result = registrar->solve({{frame.images[0], simulator.views()[0].camera}},
                                         {frame.femur, frame.tibia});
    for (int b = 0; b < 2; ++b) {
      const auto& q = result.quality[b];
      SCOPED_TRACE("frame " + std::to_string(f) + " bone " + std::to_string(b));
      EXPECT_GE(q.contour_inlier_fraction, 0.9);
      // The offset (0.5-0.9 px here) shows in the RMS ...
      EXPECT_GT(result.edge_offsets_px[b][0], 0.4);
      EXPECT_GT(q.contour_rms_px, q.contour_spread_px + 0.2);
      // ... not in the spread, which stays that of a good fit.
      EXPECT_LT(q.contour_spread_px, thresholds.suspect_contour_spread_px - 0.2);
    }
    EXPECT_EQ(registration::classifyBones(result, thresholds),
              (std::vector<std::string>{"ok", "ok"}));
  }
}

// The occluding-rod variant in extension (config/robustness/occluding_rod.yaml, its own seed):
// the femoral component's displayed rim lies a pixel or two outside its outline, which the
// registration fits as the bone's edge offset. Counted where the outline lies, most of a good
// fit's samples are beyond the inlier distance and the bone reads suspect (19 of the tracked
// trial's 60 frames, none of them failed); counted where the offset puts them, it reads ok.
TEST(Registrar, InlierTestsCountTheOutlineWhereItsEdgeOffsetPutsIt) {
  const sim::TrialSimulatorSettings s = sim::loadSimulatorSettings(
      std::string(FLUORO_SOURCE_DIR) + "/config/robustness/occluding_rod.yaml");
  const sim::TrialSimulator simulator(s);
  const auto registrar = test_support::simulatedKneeRegistrar(simulator);
  std::mt19937_64 rng(s.seed);
  sim::SimulatedFrame frame;
  for (int f = 0; f <= 6; ++f) frame = simulator.render(f, &rng);
  const geometry::XrayCamera& camera = simulator.views()[0].camera;
  const auto result = registrar->solve({{frame.images[0], camera}}, {frame.femur, frame.tibia});
  const auto error =
      registration::poseError(result.poses[0], frame.femur, camera.worldFromCamera().inverse());
  ASSERT_LT(error.translation_mm.head<2>().cwiseAbs().maxCoeff(), 1.0);
  ASSERT_LT(error.rotation_deg.cwiseAbs().maxCoeff(), 2.0);
  const registration::BoneQuality& femur = result.quality[0];
  ASSERT_LT(result.edge_offsets_px[0][0], -0.5) << "the rim must lie outside the outline";
  EXPECT_LT(femur.contour_inlier_fraction, 0.6);
  EXPECT_GT(femur.offset_inlier_fraction, 0.75);

  registration::QualitySettings where_the_outline_lies;
  where_the_outline_lies.inliers_at_edge_offset = false;
  EXPECT_NE(registration::classifyBones(result, where_the_outline_lies)[0], "ok");
  EXPECT_EQ(registration::classifyBones(result, registration::QualitySettings())[0], "ok");
  // Choosing between solutions still counts where the outline lies.
  EXPECT_DOUBLE_EQ(registration::resultRank(result, registration::QualitySettings()).second,
                   -(femur.contour_inlier_fraction + result.quality[1].contour_inlier_fraction));
}

// The edge offset's floor (RegistrationSettings::edge_offset_min_px) on the Kneel study's real
// tray seen 8 deg obliquely at 85 deg of flexion: with the offset unbounded the tray's thin plate
// slides along the beam with its offset (about 8.6 mm, offset -0.6 px); with the floor it stays
// within a few millimetres.
TEST(Registrar, EdgeOffsetFloorKeepsAnObliqueTrayFromSlidingAlongTheBeam) {
  sim::TrialSimulatorSettings s = sim::loadSimulatorSettings(
      std::string(FLUORO_SOURCE_DIR) + "/config/robustness/kneel_implants.yaml");
  s.motion.frames = 1;
  s.motion.start_flexion_deg = s.motion.max_flexion_deg = 85.0;
  s.view_yaw_deg = 8.0;
  s.view_roll_deg = -5.0;
  const SingleViewFrame scene(s, 0, 5);
  const auto& bones = scene.bones;
  const auto& frame = scene.frame;
  const auto& views = scene.views;
  const geometry::XrayCamera& camera = scene.camera();
  const Pose camera_from_fixed = scene.cameraFromFixed();
  std::vector<Pose> start = {frame.femur, frame.tibia};
  for (Pose& pose : start) {
    Pose in_camera = camera_from_fixed * pose;
    in_camera.translation().z() += 0.003;
    in_camera.linear() =
        geometry::rotationX(0.03) * geometry::rotationY(-0.03) * in_camera.linear();
    pose = camera.worldFromCamera() * in_camera;
  }
  registration::RegistrationSettings settings;
  settings.edge_offset_min_px = -std::numeric_limits<double>::infinity();
  const auto unbounded = registration::Registrar(bones, settings).solve(views, start);
  const auto unbounded_error =
      registration::poseError(unbounded.poses[1], frame.tibia, camera_from_fixed);
  ASSERT_GT(unbounded_error.translation_mm.z(), 6.0)
      << "the tray must slide without the floor for the test to mean anything";
  ASSERT_LT(unbounded.edge_offsets_px[1][0], -0.4);
  settings.edge_offset_min_px = 0.0;
  const auto floored = registration::Registrar(bones, settings).solve(views, start);
  const auto error = registration::poseError(floored.poses[1], frame.tibia, camera_from_fixed);
  EXPECT_LT(std::abs(error.translation_mm.z()), 4.5);
  EXPECT_TRUE(registration::meetsSuccessCriterion(error));
  EXPECT_GT(floored.edge_offsets_px[1][0], unbounded.edge_offsets_px[1][0] + 0.2);
}

// A stretch of the femoral component's outline that runs inside a metal rod has no edge of its
// own; the rod's borders lie 4-6 px away, where a 4 px Cauchy kernel pulls hardest. Trading the
// bone's edge offset against its depth, those samples carry the bone ~8 mm along the beam from
// its true pose, its edge offset at -1.9 px (outward; +0.3-0.5 px, inward, at the truth). The
// narrower kernel once the contour lies on its edges (robust_scale_final_px) weakens their
// pull: on this one frame the slide shrinks (to ~7 mm, offset -1.4 px); tracked, later frames
// then come back (README "Registration").
TEST(Registrar, ANarrowerFinalKernelWeakensThePullOfSamplesWithoutEdges) {
  sim::TrialSimulatorSettings s = sim::loadSimulatorSettings(
      std::string(FLUORO_SOURCE_DIR) + "/config/robustness/occluding_rod.yaml");
  s.motion.frames = 1;
  const SingleViewFrame scene(s, 0, 5);
  const auto& bones = scene.bones;
  const auto& frame = scene.frame;
  const auto& views = scene.views;
  const Pose camera_from_fixed = scene.cameraFromFixed();
  const std::vector<Pose> truth = {frame.femur, frame.tibia};
  registration::RegistrationSettings settings;
  settings.robust_scale_final_px = 0.0;  // 4 px throughout
  const auto wide = registration::Registrar(bones, settings).solve(views, truth);
  const auto wide_error = registration::poseError(wide.poses[0], frame.femur, camera_from_fixed);
  ASSERT_GT(wide_error.translation_mm.z(), 5.0)
      << "the femoral component must slide with the wide kernel for the test to mean anything";
  settings.robust_scale_final_px = 2.0;
  const auto narrow = registration::Registrar(bones, settings).solve(views, truth);
  const auto error = registration::poseError(narrow.poses[0], frame.femur, camera_from_fixed);
  EXPECT_LT(error.translation_mm.z(), wide_error.translation_mm.z() - 1.0);
  EXPECT_GT(narrow.edge_offsets_px[0][0], wide.edge_offsets_px[0][0] + 0.3);
  EXPECT_GT(narrow.quality[0].contour_inlier_fraction,
            wide.quality[0].contour_inlier_fraction + 0.1);
}
