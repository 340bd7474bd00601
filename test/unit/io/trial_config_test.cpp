#include "fluoro_tracker/io/trial_config.h"

#include <cmath>
#include <filesystem>
#include <limits>

#include "../test_support.h"

using namespace fluoro_tracker;
using test_support::TempDir;

namespace {

// Loads a one-bone trial whose `registration:` section is `registration` (flow YAML) and
// expects the load to fail with a message containing `fragment`.
void expectRegistrationRejected(const std::string& registration, const std::string& fragment) {
  SCOPED_TRACE("registration: " + registration);
  TempDir dir;
  test_support::writeText(
      dir.file("trial.yaml"),
      "bones:\n  - {name: femur, mesh: f.stl}\nregistration: " + registration + "\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("trial.yaml")), fragment);
}

}  // namespace

TEST(TrialConfig, ReadsTheContractExample) {
  TempDir dir;
  test_support::writeText(dir.file("trial.yaml"), R"(
fixed_frame: fluoro_optical
bones:
  - name: femur
    mesh: meshes/femur.stl
    mesh_units: mm
    initial_pose:
      position_m: [0.0, 0.01, 0.9]
      orientation_xyzw: [0.0, 0.0, 0.0, 1.0]
  - name: tibia
    mesh: /abs/tibia.stl
    mesh_units: m
    articular_mesh: meshes/insert.stl
joints:
  - name: knee
    parent: femur
    child: tibia
    type: knee
    contact: {enabled: true, dead_band_mm: 1.0}
    ligaments: {enabled: false}
)");
  const io::TrialConfig c = io::loadTrialConfig(dir.file("trial.yaml"));
  EXPECT_EQ(c.fixed_frame, "fluoro_optical");
  ASSERT_EQ(c.bones.size(), 2u);
  EXPECT_EQ(c.bones[0].mesh, (std::filesystem::path(dir.path()) / "meshes/femur.stl").string());
  EXPECT_EQ(c.bones[0].mesh_units, geometry::LengthUnit::kMillimetre);
  ASSERT_TRUE(c.bones[0].initial_pose.has_value());
  EXPECT_TRUE(c.bones[0].initial_pose->translation().isApprox(Eigen::Vector3d(0.0, 0.01, 0.9)));
  EXPECT_EQ(c.bones[1].mesh, "/abs/tibia.stl");
  EXPECT_EQ(c.bones[1].mesh_units, geometry::LengthUnit::kMetre);
  EXPECT_FALSE(c.bones[1].initial_pose.has_value());
  EXPECT_EQ(c.bones[1].articular_mesh,
            (std::filesystem::path(dir.path()) / "meshes/insert.stl").string());
  ASSERT_EQ(c.joints.size(), 1u);
  EXPECT_TRUE(c.joints[0].contact.enabled);
  EXPECT_DOUBLE_EQ(c.joints[0].contact.dead_band_mm, 1.0);
  EXPECT_EQ(c.joints[0].contact.measure, constraints::ContactSettings().measure);
  EXPECT_FALSE(c.joints[0].ligaments.enabled);
  EXPECT_NE(c.findBone("tibia"), nullptr);
  EXPECT_EQ(c.findBone("patella"), nullptr);
}

TEST(TrialConfig, SaveThenLoadRoundTrip) {
  TempDir dir;
  io::TrialConfig c;
  c.fixed_frame = "lab";
  io::BoneConfig femur;
  femur.name = "femur";
  femur.mesh = dir.file("models/femur.stl");
  femur.initial_pose =
      geometry::makePose(geometry::rotationZ(0.4), Eigen::Vector3d(0.01, 0.02, 1.0));
  io::BoneConfig tibia;
  tibia.name = "tibia";
  tibia.mesh = dir.file("models/tray.stl");
  tibia.articular_mesh = dir.file("models/insert.stl");
  tibia.anatomical_frame =
      geometry::makePose(geometry::rotationY(0.1), Eigen::Vector3d(0.0, -0.002, 0.001));
  c.bones = {femur, tibia};
  io::JointConfig knee;
  knee.name = "knee";
  knee.parent = "femur";
  knee.child = "tibia";
  knee.side = kinematics::Side::kLeft;
  knee.ligaments.bounds[1] = {-4.0, 5.0};
  knee.ligaments.stiffness_per_mm = 3.5;
  constraints::LigamentBundle mcl;
  mcl.name = "mcl";
  mcl.parent_insertion_m = Eigen::Vector3d(0.001, 0.002, -0.035);
  mcl.child_insertion_m = Eigen::Vector3d(-0.002, -0.06, -0.03);
  mcl.slack_length_m = 0.075;
  mcl.stiffness_per_mm = 2.0;
  knee.ligaments.bundles = {mcl};
  knee.contact.measure = constraints::ContactMeasure::kPenetrationDepth;
  knee.contact.weight = 7.5;
  knee.contact.loaded_weight = 3.0;
  knee.contact.exponent = 1.0;
  knee.contact.dead_band_mm = 0.5;
  knee.contact.max_sample_spacing_mm = 1.5;
  knee.contact.grid.spacing_m = 0.5e-3;
  knee.contact.region.box =
      Eigen::AlignedBox3d(Eigen::Vector3d(-0.04, -0.03, -0.04), Eigen::Vector3d(0.04, 0.0, 0.04));
  knee.contact.region.normal = Eigen::Vector3d(0, -1, 0);
  knee.contact.region.max_angle_deg = 80.0;
  c.joints = {knee};
  io::saveTrialConfig(dir.file("trial.yaml"), c);
  const io::TrialConfig r = io::loadTrialConfig(dir.file("trial.yaml"));
  EXPECT_EQ(r.fixed_frame, "lab");
  ASSERT_EQ(r.bones.size(), 2u);
  EXPECT_EQ(r.bones[0].mesh, femur.mesh);
  EXPECT_EQ(r.bones[1].articular_mesh, tibia.articular_mesh);
  EXPECT_TRUE(r.bones[1].anatomical_frame.matrix().isApprox(tibia.anatomical_frame.matrix(), 1e-9));
  EXPECT_TRUE(r.bones[0].anatomical_frame.matrix().isIdentity());
  ASSERT_TRUE(r.bones[0].initial_pose.has_value());
  EXPECT_TRUE(r.bones[0].initial_pose->matrix().isApprox(femur.initial_pose->matrix(), 1e-9));
  ASSERT_EQ(r.joints.size(), 1u);
  const constraints::ContactSettings& contact = r.joints[0].contact;
  EXPECT_TRUE(contact.enabled);
  EXPECT_EQ(contact.measure, constraints::ContactMeasure::kPenetrationDepth);
  EXPECT_DOUBLE_EQ(contact.weight, 7.5);
  EXPECT_DOUBLE_EQ(contact.loaded_weight, 3.0);
  EXPECT_DOUBLE_EQ(contact.exponent, 1.0);
  EXPECT_DOUBLE_EQ(contact.dead_band_mm, 0.5);
  EXPECT_DOUBLE_EQ(contact.max_sample_spacing_mm, 1.5);
  EXPECT_NEAR(contact.grid.spacing_m, 0.5e-3, 1e-12);
  EXPECT_TRUE(contact.region.box.min().isApprox(knee.contact.region.box.min()));
  EXPECT_TRUE(contact.region.box.max().isApprox(knee.contact.region.box.max()));
  EXPECT_TRUE(contact.region.normal.isApprox(Eigen::Vector3d(0, -1, 0)));
  EXPECT_DOUBLE_EQ(contact.region.max_angle_deg, 80.0);
  EXPECT_EQ(r.joints[0].side, kinematics::Side::kLeft);
  EXPECT_TRUE(r.joints[0].ligaments.enabled);
  EXPECT_DOUBLE_EQ(r.joints[0].ligaments.bounds[1].lower, -4.0);
  EXPECT_DOUBLE_EQ(r.joints[0].ligaments.bounds[1].upper, 5.0);
  EXPECT_TRUE(std::isinf(r.joints[0].ligaments.bounds[4].upper));  // distraction free
  EXPECT_DOUBLE_EQ(r.joints[0].ligaments.stiffness_per_mm, 3.5);
  ASSERT_EQ(r.joints[0].ligaments.bundles.size(), 1u);
  const constraints::LigamentBundle& bundle = r.joints[0].ligaments.bundles[0];
  EXPECT_EQ(bundle.name, "mcl");
  EXPECT_TRUE(bundle.parent_insertion_m.isApprox(mcl.parent_insertion_m, 1e-12));
  EXPECT_TRUE(bundle.child_insertion_m.isApprox(mcl.child_insertion_m, 1e-12));
  EXPECT_NEAR(bundle.slack_length_m, 0.075, 1e-12);
  EXPECT_DOUBLE_EQ(bundle.stiffness_per_mm, 2.0);
}

// Ligament bundles: insertion points in mm in each bone's mesh frame; a bad entry is named.
TEST(TrialConfig, LigamentBundlesAreReadInMillimetresAndChecked) {
  TempDir dir;
  const std::string head =
      "bones:\n  - {name: femur, mesh: f.stl}\n  - {name: tibia, mesh: t.stl}\n"
      "joints:\n  - name: knee\n    parent: femur\n    child: tibia\n    ligaments:\n"
      "      bundles:\n";
  test_support::writeText(
      dir.file("good.yaml"),
      head +
          "        - {name: lcl, parent_insertion_mm: [0, 5, 35], child_insertion_mm: "
          "[-10, -60, 38], slack_length_mm: 70}\n");
  const auto bundles = io::loadTrialConfig(dir.file("good.yaml")).joints[0].ligaments.bundles;
  ASSERT_EQ(bundles.size(), 1u);
  EXPECT_TRUE(bundles[0].parent_insertion_m.isApprox(Eigen::Vector3d(0.0, 0.005, 0.035)));
  EXPECT_TRUE(bundles[0].child_insertion_m.isApprox(Eigen::Vector3d(-0.01, -0.06, 0.038)));
  EXPECT_NEAR(bundles[0].slack_length_m, 0.07, 1e-12);
  EXPECT_DOUBLE_EQ(bundles[0].stiffness_per_mm, constraints::LigamentBundle().stiffness_per_mm);
  test_support::writeText(
      dir.file("noslack.yaml"),
      head +
          "        - {name: lcl, parent_insertion_mm: [0, 5, 35], child_insertion_mm: "
          "[-10, -60, 38]}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("noslack.yaml")),
                    "ligament bundle 'lcl': slack length must be > 0");
  test_support::writeText(
      dir.file("point.yaml"),
      head +
          "        - {name: lcl, parent_insertion_mm: [0, 5], child_insertion_mm: "
          "[-10, -60, 38], slack_length_mm: 70}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("point.yaml")),
                    "bundles[0].parent_insertion_mm needs [x, y, z] in mm");
  test_support::writeText(
      dir.file("typo.yaml"),
      head +
          "        - {name: lcl, parent_insertion: [0, 5, 35], child_insertion_mm: "
          "[-10, -60, 38], slack_length_mm: 70}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("typo.yaml")), "parent_insertion");
  test_support::writeText(
      dir.file("twice.yaml"),
      head +
          "        - {name: lcl, parent_insertion_mm: [0, 5, 35], child_insertion_mm: [-10, -60, "
          "38], slack_length_mm: 70}\n"
          "        - {name: lcl, parent_insertion_mm: [0, 5, 35], child_insertion_mm: [-10, -60, "
          "38], slack_length_mm: 70}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("twice.yaml")), "two bundles are named 'lcl'");
}

TEST(TrialConfig, ContactSectionIsCheckedAndMissingMeansDisabled) {
  TempDir dir;
  const std::string bones =
      "bones:\n  - {name: femur, mesh: f.stl}\n  - {name: tibia, mesh: t.stl}\n";
  test_support::writeText(dir.file("none.yaml"),
                          bones + "joints:\n  - {name: knee, parent: femur, child: tibia}\n");
  EXPECT_FALSE(io::loadTrialConfig(dir.file("none.yaml")).joints[0].contact.enabled);
  test_support::writeText(dir.file("measure.yaml"),
                          bones +
                              "joints:\n  - {name: knee, parent: femur, child: tibia, "
                              "contact: {measure: volume}}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("measure.yaml")), "quasi_volume");
  test_support::writeText(dir.file("key.yaml"),
                          bones +
                              "joints:\n  - {name: knee, parent: femur, child: tibia, "
                              "contact: {deadband_mm: 1}}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("key.yaml")), "unknown key 'deadband_mm'");
  test_support::writeText(dir.file("box.yaml"),
                          bones +
                              "joints:\n  - {name: knee, parent: femur, child: tibia, "
                              "contact: {region: {box_min_mm: [0, 0]}}}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("box.yaml")), "3 numbers");
}

TEST(TrialConfig, JointTypesAreCheckedAndTakeLigamentsInTheirOwnCoordinates) {
  TempDir dir;
  // A trial of a tibia and a talus with one joint between them, written as `file`.
  const auto trial = [&](const std::string& file, const std::string& joint) {
    test_support::writeText(dir.file(file),
                            "bones:\n  - {name: tibia, mesh: t.stl}\n  - {name: talus, mesh: "
                            "a.stl}\njoints:\n  - {name: j, parent: tibia, child: talus, " +
                                joint + "}\n");
    return dir.file(file);
  };
  const io::TrialConfig plain_ankle =
      io::loadTrialConfig(trial("ankle.yaml", "type: ankle, side: left"));
  EXPECT_EQ(plain_ankle.joints[0].type, "ankle");
  // No springs, and no knee's bounds either (the search's envelope reads them).
  EXPECT_FALSE(plain_ankle.joints[0].ligaments.enabled);
  for (const auto& b : plain_ankle.joints[0].ligaments.bounds) {
    EXPECT_TRUE(std::isinf(b.lower) && std::isinf(b.upper));
  }
  EXPECT_THROW_WITH(io::loadTrialConfig(trial("hip.yaml", "type: hip")), "joint type 'hip'");
  // An ankle's bounds are named and signed as its own coordinates (dorsiflexion is the knee's
  // flexion reversed); the springs act on the knee's, so they are stored so. Unlisted bounds
  // are free (the dissertation's defaults are a knee's).
  const io::TrialConfig ankle_springs = io::loadTrialConfig(
      trial("springs.yaml",
            "type: ankle, ligaments: {dorsiflexion_deg: [-40, 25], inversion_deg: [-10, 15], "
            "z_mm: [-2, 3]}"));
  const constraints::LigamentSettings& l = ankle_springs.joints[0].ligaments;
  EXPECT_TRUE(l.enabled);
  EXPECT_DOUBLE_EQ(l.bounds[0].lower, -25.0);
  EXPECT_DOUBLE_EQ(l.bounds[0].upper, 40.0);
  EXPECT_DOUBLE_EQ(l.bounds[1].lower, -10.0);
  EXPECT_DOUBLE_EQ(l.bounds[1].upper, 15.0);
  EXPECT_TRUE(std::isinf(l.bounds[2].lower) && std::isinf(l.bounds[2].upper));
  EXPECT_DOUBLE_EQ(l.bounds[5].upper, 3.0);
  // Saved in the ankle's own terms and read back the same.
  io::saveTrialConfig(dir.file("saved.yaml"), ankle_springs);
  EXPECT_NE(test_support::readText(dir.file("saved.yaml")).find("dorsiflexion_deg"),
            std::string::npos);
  const auto& reread = io::loadTrialConfig(dir.file("saved.yaml")).joints[0].ligaments;
  EXPECT_DOUBLE_EQ(reread.bounds[0].lower, -25.0);
  EXPECT_DOUBLE_EQ(reread.bounds[0].upper, 40.0);
  EXPECT_THROW_WITH(
      io::loadTrialConfig(trial("kneekey.yaml", "type: ankle, ligaments: {flexion_deg: [0, 1]}")),
      "unknown key 'flexion_deg'");
  // A shoulder's bounds are on its ISB angles (constraints/glenohumeral_springs.h), as given.
  const io::TrialConfig shoulder = io::loadTrialConfig(
      trial("shoulder.yaml",
            "type: glenohumeral, ligaments: {plane_of_elevation_deg: [-30, 120], elevation_deg: "
            "[-120, 0], axial_rotation_deg: [-40, 40]}"));
  EXPECT_DOUBLE_EQ(shoulder.joints[0].ligaments.bounds[0].lower, -30.0);
  EXPECT_DOUBLE_EQ(shoulder.joints[0].ligaments.bounds[1].lower, -120.0);
  EXPECT_DOUBLE_EQ(shoulder.joints[0].ligaments.bounds[2].upper, 40.0);
  io::saveTrialConfig(dir.file("saved_shoulder.yaml"), shoulder);
  const auto& shoulder_again = io::loadTrialConfig(dir.file("saved_shoulder.yaml")).joints[0];
  EXPECT_TRUE(shoulder_again.ligaments.enabled);
  EXPECT_DOUBLE_EQ(shoulder_again.ligaments.bounds[0].upper, 120.0);
  EXPECT_THROW_WITH(io::loadTrialConfig(trial("shoulderkey.yaml",
                                              "type: glenohumeral, ligaments: {flexion_deg: [0, "
                                              "1]}")),
                    "unknown key 'flexion_deg'");
  // A patellofemoral joint's bounds are its own coordinates (Bull et al.), stored as given: the
  // springs act on the knee coordinates of its frames turned so that these are they.
  const io::TrialConfig patella = io::loadTrialConfig(
      trial("patella.yaml",
            "type: patellofemoral, ligaments: {flexion_deg: [0, 120], lateral_tilt_deg: [-5, 15], "
            "z_mm: [-3, 8]}"));
  const constraints::LigamentSettings& p = patella.joints[0].ligaments;
  EXPECT_DOUBLE_EQ(p.bounds[0].lower, 0.0);
  EXPECT_DOUBLE_EQ(p.bounds[0].upper, 120.0);
  EXPECT_DOUBLE_EQ(p.bounds[1].lower, -5.0);
  EXPECT_DOUBLE_EQ(p.bounds[1].upper, 15.0);
  EXPECT_DOUBLE_EQ(p.bounds[5].upper, 8.0);
  io::saveTrialConfig(dir.file("saved_patella.yaml"), patella);
  EXPECT_NE(test_support::readText(dir.file("saved_patella.yaml")).find("lateral_tilt_deg"),
            std::string::npos);
  EXPECT_DOUBLE_EQ(
      io::loadTrialConfig(dir.file("saved_patella.yaml")).joints[0].ligaments.bounds[1].upper,
      15.0);
  EXPECT_THROW_WITH(io::loadTrialConfig(trial("patellakey.yaml",
                                              "type: patellofemoral, ligaments: {adduction_deg: "
                                              "[0, 1]}")),
                    "unknown key 'adduction_deg'");
  // The forearm's joints take the elbow's names: pronation about the radius' long axis.
  const io::TrialConfig forearm = io::loadTrialConfig(
      trial("forearm.yaml", "type: radioulnar, ligaments: {pronation_deg: [-80, 75]}"));
  EXPECT_EQ(forearm.joints[0].type, "radioulnar");
  EXPECT_DOUBLE_EQ(forearm.joints[0].ligaments.bounds[2].lower, -80.0);
  EXPECT_DOUBLE_EQ(forearm.joints[0].ligaments.bounds[2].upper, 75.0);
}

TEST(TrialConfig, BadYamlNamesFileKeyAndLine) {
  TempDir dir;
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("missing.yaml")), "does not exist");
  test_support::writeText(dir.file("syntax.yaml"), "bones:\n  - name: [femur\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("syntax.yaml")), "not valid YAML (line");
  test_support::writeText(dir.file("nobones.yaml"), "fixed_frame: x\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("nobones.yaml")),
                    "'bones' must be a non-empty list");
  test_support::writeText(dir.file("nomesh.yaml"), "bones:\n  - name: femur\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("nomesh.yaml")), "bones[0]: missing key 'mesh'");
  test_support::writeText(dir.file("units.yaml"),
                          "bones:\n  - {name: femur, mesh: f.stl, mesh_units: cm}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("units.yaml")), "unknown length unit 'cm'");
  test_support::writeText(dir.file("dup.yaml"),
                          "bones:\n  - {name: a, mesh: f.stl}\n  - {name: a, mesh: g.stl}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("dup.yaml")), "used twice");
  test_support::writeText(
      dir.file("quat.yaml"),
      "bones:\n  - name: a\n    mesh: f.stl\n    initial_pose: {position_m: [0,0,1], "
      "orientation_xyzw: [0,0,0,3]}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("quat.yaml")), "not a unit quaternion");
  test_support::writeText(dir.file("joint.yaml"),
                          "bones:\n  - {name: femur, mesh: f.stl}\njoints:\n  - {name: knee, "
                          "parent: femur, child: tibia}\n");
  EXPECT_THROW_WITH(io::loadTrialConfig(dir.file("joint.yaml")), "bone 'tibia' is not listed");
}

TEST(TrialConfig, RegistrationSectionFillsTheSettingsAndRejectsTypos) {
  TempDir dir;
  test_support::writeText(dir.file("trial.yaml"), R"(
bones:
  - {name: femur, mesh: f.stl}
registration:
  scales: [0.25, 1.0]
  outer_iterations: 6
  coarse_outer_iterations: 3
  tracking_scales: [0.5, 1.0]
  tracking_retry: false
  tracking_retry_inlier_drop: 0.12
  tracking_retry_min_inlier_gain: 0.03
  tracking_retry_max_inlier_loss: 0.07
  tracking_shift_search_mm: 45.0
  featureless_noise_ratio: 0.7
  tracking_recovery_registration: false
  tracking_restart_after_suspect: false
  inner_edge_margin_px: 2.5
  tracking_inner_edge_margin_px: 3.5
  tracking_prediction: constant_velocity
  robust_scale_px: 3.0
  robust_scale_final_px: 1.5
  parameterisation: parent_relative
  edge_offset_hold: false
  corner_rounding: false
  threads: 1
  rendered_edges: {enabled: true, saturation_mm: 2.5}
  covariance_offset_gradient_sd_px: 0.35
  edge_offset_min_px: 0.0
  edge_offset_tracking: {enabled: false, frame_sd_px: 0.3, drift_px: 0.05}
  edges: {clahe: true, canny_high: 60, thresholds_skip_saturated_borders: false,
          clipped_grey_margin: 0.25}
  mirror_check: {enabled: false, cost_tolerance: 0.2, outer_iterations: 3, solver_iterations: 5,
                 continued_outer_iterations: 0,
                 turn_reflection: false, mirror_reflection: false, tilt_reflection: false, max_difference_deg: 30,
                 tracking_turn_max_difference_deg: 4, tracking_tilt_reflection: false,
                 min_neutral_gain: 0.25,
                 abandon_cost_ratio: 3.5, abandon_deviation_excess: 0.5,
                 start_deviation_excess: 2.5, neutral_internal_rotation_per_flexion: 0.1}
  reflection_retry: {enabled: false, below_inlier_fraction: 0.7, min_inlier_gain: 0.1,
                     before_mirror_check: false}
  rotation_retry: {enabled: false, above_contour_spread_px: 0.6, step_deg: 4,
                   tracking_spread_rise: 1.5}
  depth_retry: {enabled: false, shifts_mm: [-10, 10, -25], light_below_inlier_fraction: 0.8,
                other_views_shift_mm: 30}
  quality: {relative_inlier_drop: 0.2, relative_inlier_spread: 2.5, relative_inlier_window: 10,
            relative_inlier_min_frames: 5, relative_inlier_trend_frames: 6,
            suspect_contour_spread_px: 0.6, suspect_contour_rms_px: 1.2,
            inliers_at_edge_offset: false, unseen_edge_distance_px: 10,
            held_by_other_views_inlier_fraction: 0.8}
)");
  const io::TrialConfig c = io::loadTrialConfig(dir.file("trial.yaml"));
  EXPECT_EQ(c.registration.parameterisation,
            registration::RegistrationSettings::Parameterisation::kParentRelative);
  EXPECT_FALSE(c.registration.mirror_check.enabled);
  EXPECT_EQ(c.registration.edge_offset_min_px, 0.0);
  EXPECT_DOUBLE_EQ(c.registration.covariance_offset_gradient_sd_px, 0.35);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.cost_tolerance, 0.2);
  EXPECT_EQ(c.registration.mirror_check.outer_iterations, 3);
  EXPECT_EQ(c.registration.mirror_check.solver_iterations, 5);
  EXPECT_EQ(c.registration.mirror_check.continued_outer_iterations, 0);
  EXPECT_FALSE(c.registration.mirror_check.turn_reflection);
  EXPECT_FALSE(c.registration.mirror_check.mirror_reflection);
  EXPECT_FALSE(c.registration.mirror_check.tilt_reflection);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.max_difference_deg, 30.0);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.tracking_turn_max_difference_deg, 4.0);
  EXPECT_FALSE(c.registration.mirror_check.tracking_tilt_reflection);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.min_neutral_gain, 0.25);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.abandon_cost_ratio, 3.5);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.abandon_deviation_excess, 0.5);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.start_deviation_excess, 2.5);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.neutral_internal_rotation_per_flexion, 0.1);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.min_difference_deg,
                   registration::MirrorCheckSettings().min_difference_deg);
  EXPECT_FALSE(c.registration.reflection_retry.enabled);
  EXPECT_DOUBLE_EQ(c.registration.reflection_retry.below_inlier_fraction, 0.7);
  EXPECT_DOUBLE_EQ(c.registration.reflection_retry.min_inlier_gain, 0.1);
  EXPECT_FALSE(c.registration.reflection_retry.before_mirror_check);
  EXPECT_FALSE(c.registration.rotation_retry.enabled);
  EXPECT_DOUBLE_EQ(c.registration.rotation_retry.above_contour_spread_px, 0.6);
  EXPECT_DOUBLE_EQ(c.registration.rotation_retry.step_deg, 4.0);
  EXPECT_DOUBLE_EQ(c.registration.rotation_retry.tracking_spread_rise, 1.5);
  EXPECT_FALSE(c.registration.depth_retry.enabled);
  EXPECT_EQ(c.registration.depth_retry.shifts_mm, (std::vector<double>{-10.0, 10.0, -25.0}));
  EXPECT_DOUBLE_EQ(c.registration.depth_retry.light_below_inlier_fraction, 0.8);
  EXPECT_DOUBLE_EQ(c.registration.depth_retry.other_views_shift_mm, 30.0);
  EXPECT_FALSE(c.registration.edges.thresholds_skip_saturated_borders);
  EXPECT_DOUBLE_EQ(c.registration.edges.clipped_grey_margin, 0.25);
  EXPECT_DOUBLE_EQ(c.registration.quality.relative_inlier_drop, 0.2);
  EXPECT_DOUBLE_EQ(c.registration.quality.relative_inlier_spread, 2.5);
  EXPECT_EQ(c.registration.quality.relative_inlier_window, 10);
  EXPECT_EQ(c.registration.quality.relative_inlier_min_frames, 5);
  EXPECT_EQ(c.registration.quality.relative_inlier_trend_frames, 6);
  EXPECT_DOUBLE_EQ(c.registration.quality.suspect_contour_spread_px, 0.6);
  EXPECT_DOUBLE_EQ(c.registration.quality.suspect_contour_rms_px, 1.2);
  EXPECT_DOUBLE_EQ(c.registration.quality.unseen_edge_distance_px, 10.0);
  EXPECT_DOUBLE_EQ(c.registration.quality.held_by_other_views_inlier_fraction, 0.8);
  EXPECT_FALSE(c.registration.quality.inliers_at_edge_offset);
  EXPECT_DOUBLE_EQ(c.registration.quality.suspect_inlier_fraction,
                   registration::QualitySettings().suspect_inlier_fraction);
  EXPECT_EQ(c.registration.scales, (std::vector<double>{0.25, 1.0}));
  EXPECT_EQ(c.registration.outer_iterations, 6);
  EXPECT_EQ(c.registration.coarse_outer_iterations, 3);
  EXPECT_EQ(c.registration.tracking_scales, (std::vector<double>{0.5, 1.0}));
  EXPECT_FALSE(c.registration.tracking_retry);
  EXPECT_DOUBLE_EQ(c.registration.tracking_retry_inlier_drop, 0.12);
  EXPECT_DOUBLE_EQ(c.registration.tracking_retry_min_inlier_gain, 0.03);
  EXPECT_DOUBLE_EQ(c.registration.tracking_retry_max_inlier_loss, 0.07);
  EXPECT_DOUBLE_EQ(c.registration.tracking_shift_search_mm, 45.0);
  EXPECT_DOUBLE_EQ(c.registration.featureless_noise_ratio, 0.7);
  EXPECT_FALSE(c.registration.tracking_recovery_registration);
  EXPECT_FALSE(c.registration.tracking_restart_after_suspect);
  EXPECT_DOUBLE_EQ(c.registration.inner_edge_margin_px, 2.5);
  EXPECT_DOUBLE_EQ(c.registration.tracking_inner_edge_margin_px, 3.5);
  EXPECT_EQ(c.registration.tracking_prediction,
            registration::RegistrationSettings::TrackingPrediction::kConstantVelocity);
  EXPECT_DOUBLE_EQ(c.registration.robust_scale_px, 3.0);
  EXPECT_DOUBLE_EQ(c.registration.robust_scale_final_px, 1.5);
  EXPECT_FALSE(c.registration.edge_offset_hold);
  EXPECT_FALSE(c.registration.corner_rounding);
  EXPECT_EQ(c.registration.threads, 1);
  EXPECT_TRUE(c.registration.rendered_edges.enabled);
  EXPECT_DOUBLE_EQ(c.registration.rendered_edges.saturation_mm, 2.5);
  EXPECT_FALSE(c.registration.edge_offset_tracking.enabled);
  EXPECT_DOUBLE_EQ(c.registration.edge_offset_tracking.frame_sd_px, 0.3);
  EXPECT_DOUBLE_EQ(c.registration.edge_offset_tracking.drift_px, 0.05);
  EXPECT_TRUE(c.registration.edges.clahe);
  EXPECT_DOUBLE_EQ(c.registration.edges.canny_high, 60.0);
  EXPECT_EQ(c.registration.solver_iterations,
            registration::RegistrationSettings().solver_iterations);

  test_support::writeText(dir.file("staged.yaml"), R"(
bones:
  - {name: femur, mesh: f.stl, image_weight: 2.0}
registration:
  stages:
    - {outer_iterations: 2, contact: false, image_weights: {femur: 2.0, tibia: 1.0}}
    - {outer_iterations: 3, solver_iterations: 5}
)");
  const io::TrialConfig staged = io::loadTrialConfig(dir.file("staged.yaml"));
  EXPECT_DOUBLE_EQ(staged.bones[0].image_weight, 2.0);
  ASSERT_EQ(staged.registration.stages.size(), 2u);
  EXPECT_EQ(staged.registration.stages[0].outer_iterations, 2);
  EXPECT_FALSE(staged.registration.stages[0].contact);
  EXPECT_TRUE(staged.registration.stages[0].ligaments);
  EXPECT_DOUBLE_EQ(staged.registration.stages[0].imageWeight("femur"), 2.0);
  EXPECT_DOUBLE_EQ(staged.registration.stages[0].imageWeight("patella"), 1.0);
  EXPECT_EQ(staged.registration.stages[1].solver_iterations, 5);
  EXPECT_TRUE(staged.registration.stages[1].contact);
  expectRegistrationRejected("{stages: [{outer: 2}]}", "unknown key 'outer'");
  expectRegistrationRejected("{outer_iteration: 3}", "unknown key 'outer_iteration'");
  expectRegistrationRejected("{scales: [2.0]}", "scales must be in (0, 1]");
  expectRegistrationRejected("{parameterisation: relative}",
                             "parameterisation 'relative' is not one of absolute, parent_relative");
  expectRegistrationRejected("{tracking_scales: []}", "tracking_scales must not be empty");
  expectRegistrationRejected("{tracking_prediction: kalman}",
                             "tracking_prediction 'kalman' is not one of");
  expectRegistrationRejected("{robust_scale_final_px: .nan}", "robust_scale_final_px must be");
  expectRegistrationRejected("{edge_offset_min_px: .nan}", "edge_offset_min_px must be a number");
  expectRegistrationRejected("{covariance_offset_gradient_sd_px: -0.1}",
                             "covariance_offset_gradient_sd_px must be");
  expectRegistrationRejected("{covariance_offset_gradient_sd_px: .inf}",
                             "covariance_offset_gradient_sd_px must be");
  expectRegistrationRejected("{mirror_check: {cost_tolerance: -0.1}}", "mirror_check needs");
  expectRegistrationRejected("{mirror_check: {min_neutral_gain: -0.1}}", "min_neutral_gain >= 0");
  expectRegistrationRejected("{mirror_check: {neutral_internal_rotation_per_flexion: .inf}}",
                             "finite neutral_internal_rotation_per_flexion");
  expectRegistrationRejected("{mirror_check: {abandon_cost_ratio: 0}}", "abandon_cost_ratio > 0");
  expectRegistrationRejected("{mirror_check: {abandon_deviation_excess: -1}}",
                             "abandon_deviation_excess > 0");
  expectRegistrationRejected("{mirror_check: {start_deviation_excess: .nan}}",
                             "start_deviation_excess > 0");
  expectRegistrationRejected("{inner_edge_margin_px: -1}",
                             "inner_edge_margin_px and tracking_inner_edge_margin_px must be");
  expectRegistrationRejected("{tracking_shift_search_mm: -1}",
                             "tracking_shift_search_mm must be finite and >= 0");
  expectRegistrationRejected("{featureless_noise_ratio: -0.5}",
                             "featureless_noise_ratio must be finite and >= 0");
  expectRegistrationRejected("{tracking_inner_edge_margin_px: .inf}",
                             "inner_edge_margin_px and tracking_inner_edge_margin_px must be");
  expectRegistrationRejected("{tracking_retry_inlier_drop: -0.1}",
                             "tracking_retry_inlier_drop must be in [0, 1]");
  expectRegistrationRejected("{tracking_retry_min_inlier_gain: .nan}",
                             "tracking_retry_min_inlier_gain >= 0");
  expectRegistrationRejected("{tracking_retry_max_inlier_loss: -0.1}",
                             "tracking_retry_max_inlier_loss must be in [0, 1]");
  expectRegistrationRejected("{reflection_retry: {below_inlier_fraction: 1.5}}",
                             "reflection_retry needs below_inlier_fraction in [0, 1]");
  expectRegistrationRejected("{reflection_retry: {min_inlier_gain: -0.1}}", "min_inlier_gain >= 0");
  expectRegistrationRejected("{rotation_retry: {step_deg: 0}}", "step_deg > 0");
  expectRegistrationRejected("{rotation_retry: {above_contour_spread_px: -1}}",
                             "above_contour_spread_px >= 0");
  expectRegistrationRejected("{rotation_retry: {tracking_spread_rise: -1}}",
                             "tracking_spread_rise >= 0");
  expectRegistrationRejected("{reflection_retry: {min_inlier_gains: 0.1}}", "min_inlier_gains");
  expectRegistrationRejected("{depth_retry: {shifts_mm: [-15, 0]}}",
                             "depth_retry: shifts_mm must be finite and non-zero");
  expectRegistrationRejected("{depth_retry: {light_below_inlier_fraction: 1.5}}",
                             "light_below_inlier_fraction must be in [0, 1]");
  expectRegistrationRejected("{depth_retry: {other_views_shift_mm: -5}}",
                             "other_views_shift_mm must be >= 0");
  expectRegistrationRejected("{quality: {relative_inlier_drop: -0.1}}",
                             "relative_inlier_drop must be in [0, 1]");
  expectRegistrationRejected("{quality: {relative_inlier_spread: -1}}",
                             "relative_inlier_spread must be >= 0");
  expectRegistrationRejected("{quality: {suspect_contour_spread_px: -0.5}}",
                             "suspect_contour_spread_px must be >= 0");
  expectRegistrationRejected(
      "{quality: {relative_inlier_window: 4, relative_inlier_min_frames: 5}}",
      "relative_inlier_min_frames in [1, relative_inlier_window]");
  expectRegistrationRejected("{quality: {relative_inlier_trend_frames: 2}}",
                             "relative_inlier_trend_frames must be 0 (off) or >= 3");
  expectRegistrationRejected("{quality: {held_by_other_views_inlier_fraction: 1.5}}",
                             "held_by_other_views_inlier_fraction must be in [0, 1]");
  expectRegistrationRejected("{edges: {edge_significance_low_ratio: 1.5}}",
                             "edge_significance_low_ratio in (0, 1]");
  expectRegistrationRejected("{edges: {clipped_grey_margin: -0.1}}",
                             "clipped_grey_margin must be in [0, 1)");
}

TEST(TrialConfig, ShippedTemplateLoadsAndStatesTheDefaults) {
  const io::TrialConfig c =
      io::loadTrialConfig(std::string(FLUORO_SOURCE_DIR) + "/config/trial_template.yaml");
  ASSERT_EQ(c.bones.size(), 2u);
  EXPECT_FALSE(c.bones[1].articular_mesh.empty());
  const registration::RegistrationSettings d;
  EXPECT_EQ(c.registration.scales, d.scales);
  EXPECT_EQ(c.registration.coarse_outer_iterations, d.coarse_outer_iterations);
  EXPECT_EQ(c.registration.tracking_scales, d.tracking_scales);
  EXPECT_EQ(c.registration.tracking_retry, d.tracking_retry);
  EXPECT_DOUBLE_EQ(c.registration.tracking_shift_search_mm, d.tracking_shift_search_mm);
  EXPECT_DOUBLE_EQ(c.registration.featureless_noise_ratio, d.featureless_noise_ratio);
  EXPECT_EQ(c.registration.tracking_recovery_registration, d.tracking_recovery_registration);
  EXPECT_EQ(c.registration.tracking_restart_after_suspect, d.tracking_restart_after_suspect);
  EXPECT_EQ(c.registration.outer_iterations, d.outer_iterations);
  EXPECT_EQ(c.registration.solver_iterations, d.solver_iterations);
  EXPECT_DOUBLE_EQ(c.registration.robust_scale_px, d.robust_scale_px);
  EXPECT_DOUBLE_EQ(c.registration.robust_scale_final_px, d.robust_scale_final_px);
  EXPECT_DOUBLE_EQ(c.registration.roi_margin_px, d.roi_margin_px);
  EXPECT_DOUBLE_EQ(c.registration.reverse_term_weight, d.reverse_term_weight);
  EXPECT_DOUBLE_EQ(c.registration.reverse_band_px, d.reverse_band_px);
  EXPECT_DOUBLE_EQ(c.registration.max_translation_from_start_m, d.max_translation_from_start_m);
  EXPECT_DOUBLE_EQ(c.registration.converged_rotation_rad, d.converged_rotation_rad);
  EXPECT_DOUBLE_EQ(c.registration.edges.max_distance_px, d.edges.max_distance_px);
  EXPECT_DOUBLE_EQ(c.registration.edges.auto_high_fraction, d.edges.auto_high_fraction);
  EXPECT_EQ(c.registration.edges.clahe, d.edges.clahe);
  EXPECT_EQ(c.registration.edges.thresholds_skip_saturated_borders,
            d.edges.thresholds_skip_saturated_borders);
  EXPECT_DOUBLE_EQ(c.registration.edges.min_edge_significance, d.edges.min_edge_significance);
  EXPECT_DOUBLE_EQ(c.registration.edges.edge_significance_low_ratio,
                   d.edges.edge_significance_low_ratio);
  EXPECT_DOUBLE_EQ(c.registration.edges.line_distance_band_px, d.edges.line_distance_band_px);
  EXPECT_DOUBLE_EQ(c.registration.edges.clipped_grey_margin, d.edges.clipped_grey_margin);
  EXPECT_EQ(c.registration.edge_offset_model, d.edge_offset_model);
  EXPECT_EQ(c.registration.parameterisation, d.parameterisation);
  EXPECT_EQ(c.registration.tracking_prediction, d.tracking_prediction);
  EXPECT_DOUBLE_EQ(c.registration.edge_offset_prior_px, d.edge_offset_prior_px);
  EXPECT_DOUBLE_EQ(c.registration.edge_offset_min_px, d.edge_offset_min_px);
  EXPECT_EQ(c.registration.edge_offset_hold, d.edge_offset_hold);
  EXPECT_EQ(c.registration.corner_rounding, d.corner_rounding);
  EXPECT_EQ(c.registration.threads, d.threads);
  EXPECT_EQ(c.registration.rendered_edges.enabled, d.rendered_edges.enabled);
  EXPECT_EQ(c.registration.rendered_edges.saturation_mm, d.rendered_edges.saturation_mm);
  EXPECT_DOUBLE_EQ(c.registration.covariance_offset_gradient_sd_px,
                   d.covariance_offset_gradient_sd_px);
  EXPECT_EQ(c.registration.contact_from_outer_iteration, d.contact_from_outer_iteration);
  EXPECT_EQ(c.registration.mirror_check.enabled, d.mirror_check.enabled);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.cost_tolerance, d.mirror_check.cost_tolerance);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.min_difference_deg,
                   d.mirror_check.min_difference_deg);
  EXPECT_EQ(c.registration.mirror_check.outer_iterations, d.mirror_check.outer_iterations);
  EXPECT_EQ(c.registration.mirror_check.solver_iterations, d.mirror_check.solver_iterations);
  EXPECT_EQ(c.registration.mirror_check.turn_reflection, d.mirror_check.turn_reflection);
  EXPECT_EQ(c.registration.mirror_check.mirror_reflection, d.mirror_check.mirror_reflection);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.tracking_turn_max_difference_deg,
                   d.mirror_check.tracking_turn_max_difference_deg);
  EXPECT_EQ(c.registration.mirror_check.tracking_tilt_reflection,
            d.mirror_check.tracking_tilt_reflection);
  EXPECT_DOUBLE_EQ(c.registration.mirror_check.neutral_internal_rotation_per_flexion,
                   d.mirror_check.neutral_internal_rotation_per_flexion);
  EXPECT_EQ(c.registration.reflection_retry.enabled, d.reflection_retry.enabled);
  EXPECT_DOUBLE_EQ(c.registration.reflection_retry.below_inlier_fraction,
                   d.reflection_retry.below_inlier_fraction);
  EXPECT_DOUBLE_EQ(c.registration.reflection_retry.min_inlier_gain,
                   d.reflection_retry.min_inlier_gain);
  EXPECT_EQ(c.registration.reflection_retry.before_mirror_check,
            d.reflection_retry.before_mirror_check);
  EXPECT_EQ(c.registration.rotation_retry.enabled, d.rotation_retry.enabled);
  EXPECT_DOUBLE_EQ(c.registration.rotation_retry.above_contour_spread_px,
                   d.rotation_retry.above_contour_spread_px);
  EXPECT_DOUBLE_EQ(c.registration.rotation_retry.step_deg, d.rotation_retry.step_deg);
  EXPECT_DOUBLE_EQ(c.registration.rotation_retry.tracking_spread_rise,
                   d.rotation_retry.tracking_spread_rise);
  EXPECT_EQ(c.registration.depth_retry.enabled, d.depth_retry.enabled);
  EXPECT_EQ(c.registration.depth_retry.shifts_mm, d.depth_retry.shifts_mm);
  EXPECT_EQ(c.registration.depth_retry.light_below_inlier_fraction,
            d.depth_retry.light_below_inlier_fraction);
  EXPECT_DOUBLE_EQ(c.registration.quality.relative_inlier_drop, d.quality.relative_inlier_drop);
  EXPECT_DOUBLE_EQ(c.registration.quality.relative_inlier_spread, d.quality.relative_inlier_spread);
  EXPECT_EQ(c.registration.quality.relative_inlier_window, d.quality.relative_inlier_window);
  EXPECT_EQ(c.registration.quality.relative_inlier_min_frames,
            d.quality.relative_inlier_min_frames);
  EXPECT_EQ(c.registration.quality.relative_inlier_trend_frames,
            d.quality.relative_inlier_trend_frames);
  ASSERT_EQ(c.joints.size(), 1u);
  const constraints::ContactSettings contact;
  EXPECT_TRUE(c.joints[0].contact.enabled);
  EXPECT_EQ(c.joints[0].contact.measure, contact.measure);
  EXPECT_DOUBLE_EQ(c.joints[0].contact.weight, contact.weight);
  EXPECT_DOUBLE_EQ(c.joints[0].contact.exponent, contact.exponent);
  EXPECT_DOUBLE_EQ(c.joints[0].contact.loaded_weight, contact.loaded_weight);
  EXPECT_DOUBLE_EQ(c.joints[0].contact.dead_band_mm, contact.dead_band_mm);
  EXPECT_DOUBLE_EQ(c.joints[0].contact.max_sample_spacing_mm, contact.max_sample_spacing_mm);
  EXPECT_NEAR(c.joints[0].contact.grid.spacing_m, contact.grid.spacing_m, 1e-12);
  EXPECT_NEAR(c.joints[0].contact.grid.margin_m, contact.grid.margin_m, 1e-12);
  EXPECT_NEAR(c.joints[0].contact.grid.exact_band_m, contact.grid.exact_band_m, 1e-12);
  const constraints::LigamentSettings ligaments;
  EXPECT_TRUE(c.joints[0].ligaments.enabled);
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(c.joints[0].ligaments.bounds[k].lower, ligaments.bounds[k].lower) << k;
    EXPECT_EQ(c.joints[0].ligaments.bounds[k].upper, ligaments.bounds[k].upper) << k;
  }
  EXPECT_DOUBLE_EQ(c.joints[0].ligaments.stiffness_per_deg, ligaments.stiffness_per_deg);
  EXPECT_DOUBLE_EQ(c.joints[0].ligaments.stiffness_per_mm, ligaments.stiffness_per_mm);
  EXPECT_EQ(c.joints[0].side, kinematics::Side::kRight);
  const registration::PoseSearchSettings search;
  EXPECT_EQ(c.search.refined_per_bone, search.refined_per_bone);
  EXPECT_EQ(c.search.wide_refined_per_bone, search.wide_refined_per_bone);
  EXPECT_EQ(c.search.envelope_extra_refined, search.envelope_extra_refined);
  EXPECT_EQ(c.search.fine_envelope, search.fine_envelope);
  EXPECT_DOUBLE_EQ(c.search.fine_envelope_neighbour_inliers,
                   search.fine_envelope_neighbour_inliers);
  EXPECT_DOUBLE_EQ(c.search.fine_envelope_flexion_step_deg, search.fine_envelope_flexion_step_deg);
  EXPECT_DOUBLE_EQ(c.search.fine_envelope_anterior_step_mm, search.fine_envelope_anterior_step_mm);
  EXPECT_DOUBLE_EQ(c.search.wide_screening_px, search.wide_screening_px);
  EXPECT_DOUBLE_EQ(c.search.screening_scale, search.screening_scale);
  EXPECT_DOUBLE_EQ(c.search.edge_high_fraction, search.edge_high_fraction);
  EXPECT_DOUBLE_EQ(c.search.retry_edge_high_fraction, search.retry_edge_high_fraction);
  EXPECT_EQ(c.search.rescue_depth_factors, search.rescue_depth_factors);
  EXPECT_EQ(c.search.edge_match_depth_factors, search.edge_match_depth_factors);
  EXPECT_EQ(c.search.edge_match_nearer_depth_factors, search.edge_match_nearer_depth_factors);
  EXPECT_EQ(c.search.edge_match_shape_regions, search.edge_match_shape_regions);
  EXPECT_DOUBLE_EQ(c.search.edge_match_partner_depth_gap, search.edge_match_partner_depth_gap);
}

TEST(TrialConfig, SearchSectionFillsTheSettingsAndRejectsBadValues) {
  TempDir dir;
  test_support::writeText(dir.file("trial.yaml"), R"(
bones:
  - {name: femur, mesh: f.stl}
registration:
  search: {refined_per_bone: 3, wide_refined_per_bone: 0, wide_screening_px: 3.0,
           envelope_extra_refined: 5, edge_high_fraction: 0.2, retry_edge_high_fraction: 0,
           rescue_depth_factors: [0.95, 1.05], fine_envelope: false,
           fine_envelope_neighbour_inliers: 0.8, fine_envelope_flexion_step_deg: 4,
           fine_envelope_anterior_step_mm: 3, edge_match_depth_factors: [1.0, 0.9],
           edge_match_nearer_depth_factors: [], edge_match_shape_regions: 1,
           edge_match_partner_depth_gap: 0.2}
)");
  const io::TrialConfig c = io::loadTrialConfig(dir.file("trial.yaml"));
  EXPECT_EQ(c.search.refined_per_bone, 3);
  EXPECT_EQ(c.search.wide_refined_per_bone, 0);
  EXPECT_EQ(c.search.envelope_extra_refined, 5);
  EXPECT_DOUBLE_EQ(c.search.wide_screening_px, 3.0);
  EXPECT_DOUBLE_EQ(c.search.edge_high_fraction, 0.2);
  EXPECT_DOUBLE_EQ(c.search.retry_edge_high_fraction, 0.0);
  EXPECT_EQ(c.search.rescue_depth_factors, (std::vector<double>{0.95, 1.05}));
  EXPECT_FALSE(c.search.fine_envelope);
  EXPECT_DOUBLE_EQ(c.search.fine_envelope_neighbour_inliers, 0.8);
  EXPECT_DOUBLE_EQ(c.search.fine_envelope_flexion_step_deg, 4.0);
  EXPECT_DOUBLE_EQ(c.search.fine_envelope_anterior_step_mm, 3.0);
  EXPECT_EQ(c.search.edge_match_depth_factors, (std::vector<double>{1.0, 0.9}));
  EXPECT_TRUE(c.search.edge_match_nearer_depth_factors.empty());
  EXPECT_EQ(c.search.edge_match_shape_regions, 1);
  EXPECT_DOUBLE_EQ(c.search.edge_match_partner_depth_gap, 0.2);
  expectRegistrationRejected("{search: {wide_screening_px: 0.5}}", "wide_screening_px >= 1");
  expectRegistrationRejected("{search: {envelope_extra_refined: -1}}", "envelope_extra_refined");
  expectRegistrationRejected("{search: {edge_high_fraction: 0}}", "edge_high_fraction");
  expectRegistrationRejected("{search: {retry_edge_high_fraction: 1.5}}",
                             "retry_edge_high_fraction");
  expectRegistrationRejected("{search: {rescue_depth_factors: [0.9, 1.0]}}",
                             "rescue_depth_factors");
  expectRegistrationRejected("{search: {rescue_depth_factors: [-1.1]}}", "rescue_depth_factors");
  expectRegistrationRejected("{search: {edge_match_depth_factors: [1.0, 0.4]}}",
                             "edge_match_depth_factors");
  expectRegistrationRejected("{search: {edge_match_nearer_depth_factors: [2.5]}}",
                             "edge_match_nearer_depth_factors");
  expectRegistrationRejected("{search: {edge_match_shape_regions: -1}}",
                             "edge_match_shape_regions >= 0");
  expectRegistrationRejected("{search: {edge_match_partner_depth_gap: .nan}}",
                             "edge_match_partner_depth_gap >= 0");
  expectRegistrationRejected("{search: {fine_envelope_flexion_step_deg: 0.5}}",
                             "fine_envelope_flexion_step_deg");
  expectRegistrationRejected("{search: {fine_envelope_neighbour_inliers: 1.5}}",
                             "fine_envelope_neighbour_inliers");
}
