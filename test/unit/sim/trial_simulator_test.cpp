#include "fluoro_tracker/sim/trial_simulator.h"

#include <opencv2/imgproc.hpp>
#include "../test_support.h"

#include "fluoro_tracker/imaging/lens_distortion.h"
#include "fluoro_tracker/imaging/renderer.h"

using namespace fluoro_tracker;
using test_support::TempDir;

namespace {

sim::TrialSimulatorSettings smallTrial(int views) {
  sim::TrialSimulatorSettings s;
  s.image_width = 512;
  s.image_height = 512;
  s.pixel_spacing_mm = 0.76;
  s.views = views;
  s.motion.frames = 5;
  return s;
}

}  // namespace

TEST(TrialSimulator, ImplantsAreInViewAndDarkerThanTissue) {
  const sim::TrialSimulator simulator(smallTrial(1));
  ASSERT_EQ(simulator.views().size(), 1u);
  EXPECT_EQ(simulator.fixedFrame(), "fluoro_optical");
  EXPECT_EQ(simulator.views()[0].camera.frameId(), "fluoro_optical");
  std::mt19937_64 rng(1);
  for (int i = 0; i < simulator.frameCount(); ++i) {
    const sim::SimulatedFrame frame = simulator.render(i, &rng);
    ASSERT_EQ(frame.images.size(), 1u);
    EXPECT_TRUE(geometry::isValidPose(frame.femur));
    EXPECT_TRUE(geometry::isValidPose(frame.tibia));
    const auto& camera = simulator.views()[0].camera;
    // Where the beam crosses the femoral component the frame is darker than the soft tissue
    // around it.
    const cv::Mat femur_path =
        imaging::Renderer::pathLength(camera, simulator.implants().femoral_component, frame.femur);
    const cv::Mat metal = femur_path > 0.003;
    const cv::Mat around = (femur_path == 0.0);
    ASSERT_GT(cv::countNonZero(metal), 200) << "femoral component not in view at frame " << i;
    const double metal_grey = cv::mean(frame.images[0], metal)[0];
    cv::Mat near_mask;
    cv::dilate(metal, near_mask, cv::Mat(), cv::Point(-1, -1), 15);
    const double tissue_grey = cv::mean(frame.images[0], near_mask & around)[0];
    EXPECT_LT(metal_grey + 60.0, tissue_grey) << "frame " << i;
  }
}

TEST(TrialSimulator, SameSeedSameFramesAndStampsAdvance) {
  const sim::TrialSimulator simulator(smallTrial(1));
  std::mt19937_64 a(42);
  std::mt19937_64 b(42);
  const auto f1 = simulator.render(2, &a);
  const auto f2 = simulator.render(2, &b);
  EXPECT_EQ(cv::norm(f1.images[0], f2.images[0], cv::NORM_INF), 0.0);
  EXPECT_NEAR(simulator.truth(3).stamp_s - simulator.truth(2).stamp_s, 1.0 / 30.0, 1e-12);
  EXPECT_THROW_WITH(simulator.truth(5), "outside");
}

TEST(TrialSimulator, BiplaneViewsSeeTheKneeFromDifferentDirections) {
  const sim::TrialSimulator simulator(smallTrial(2));
  ASSERT_EQ(simulator.views().size(), 2u);
  EXPECT_EQ(simulator.fixedFrame(), "lab");
  EXPECT_EQ(simulator.views()[1].camera.frameId(), "fluoro2_optical");
  const Eigen::Vector3d beam1 = simulator.views()[0].camera.worldFromCamera().linear().col(2);
  const Eigen::Vector3d beam2 = simulator.views()[1].camera.worldFromCamera().linear().col(2);
  EXPECT_NEAR(std::acos(beam1.dot(beam2)) * 180.0 / M_PI, 55.0, 1e-9);
  const sim::SimulatedFrame frame = simulator.truth(0);
  for (const auto& view : simulator.views()) {
    Eigen::Vector2d px;
    const geometry::Pose camera_from_femur = view.camera.worldFromCamera().inverse() * frame.femur;
    ASSERT_TRUE(view.camera.project(camera_from_femur.translation(), &px));
    EXPECT_TRUE(view.camera.contains(px)) << view.name;
  }
}

TEST(TrialSimulator, TrialConfigPointsAtWrittenModels) {
  TempDir dir;
  const sim::TrialSimulator simulator(smallTrial(1));
  simulator.writeModels(dir.file("models"));
  io::saveTrialConfig(dir.file("trial.yaml"), simulator.trialConfig(dir.file("models")));
  const io::TrialConfig config = io::loadTrialConfig(dir.file("trial.yaml"));
  ASSERT_EQ(config.bones.size(), 2u);
  for (const auto& bone : config.bones) {
    const geometry::Mesh mesh = geometry::Mesh::load(bone.mesh);
    EXPECT_TRUE(mesh.topology().isClosed());
    ASSERT_TRUE(bone.initial_pose.has_value());
  }
  EXPECT_TRUE(config.bones[0].initial_pose->isApprox(simulator.truth(0).femur, 1e-9));
  EXPECT_FALSE(config.bones[1].articular_mesh.empty());
  // The saved model is the simulated one (mm on disk, m in memory).
  EXPECT_NEAR(geometry::Mesh::load(config.bones[0].mesh).volume(),
              simulator.implants().femoral_component.volume(), 1e-9);
}

TEST(TrialSimulator, SettingsFileOverridesDefaultsAndRejectsTypos) {
  TempDir dir;
  test_support::writeText(
      dir.file("sim.yaml"),
      "views: 2\nmotion: {frames: 7, max_flexion_deg: 80}\ndetector: {bit_depth: 16}\n");
  const auto s = sim::loadSimulatorSettings(dir.file("sim.yaml"));
  EXPECT_EQ(s.views, 2);
  EXPECT_EQ(s.motion.frames, 7);
  EXPECT_DOUBLE_EQ(s.motion.max_flexion_deg, 80.0);
  EXPECT_EQ(s.detector.bit_depth, 16);
  EXPECT_EQ(s.image_width, 1024);  // default kept
  test_support::writeText(dir.file("typo.yaml"), "motion: {frame: 7}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("typo.yaml")), "unknown key 'frame'");
  test_support::writeText(dir.file("bad.yaml"), "views: 3\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("bad.yaml")), "views must be 1 or 2");
  test_support::writeText(dir.file("type.yaml"), "image_width: wide\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("type.yaml")), "image_width");
}

TEST(TrialSimulator, ShippedConfigLoadsAndStatesTheDefaults) {
  const auto s =
      sim::loadSimulatorSettings(std::string(FLUORO_SOURCE_DIR) + "/config/simulate_knee.yaml");
  const sim::TrialSimulatorSettings d;
  EXPECT_EQ(s.image_width, d.image_width);
  EXPECT_EQ(s.views, d.views);
  EXPECT_EQ(s.motion.frames, d.motion.frames);
  EXPECT_DOUBLE_EQ(s.motion.max_flexion_deg, d.motion.max_flexion_deg);
  EXPECT_DOUBLE_EQ(s.detector.scatter_strength, d.detector.scatter_strength);
  EXPECT_DOUBLE_EQ(s.detector.scatter_sigma_mm, d.detector.scatter_sigma_mm);
  EXPECT_DOUBLE_EQ(s.detector.window_max_attenuation, d.detector.window_max_attenuation);
  EXPECT_DOUBLE_EQ(s.detector.collimator_radius_fraction, d.detector.collimator_radius_fraction);
  EXPECT_DOUBLE_EQ(s.implants.width_mm, d.implants.width_mm);
  EXPECT_DOUBLE_EQ(s.implants.box_width_mm, d.implants.box_width_mm);
  EXPECT_DOUBLE_EQ(s.implants.post_width_mm, d.implants.post_width_mm);
  EXPECT_DOUBLE_EQ(s.implants.post_length_mm, d.implants.post_length_mm);
  EXPECT_DOUBLE_EQ(s.implants.post_height_mm, d.implants.post_height_mm);
  EXPECT_DOUBLE_EQ(s.implants.post_offset_mm, d.implants.post_offset_mm);
  EXPECT_DOUBLE_EQ(s.occluder_rod_radius_mm, d.occluder_rod_radius_mm);
  EXPECT_EQ(s.occluder_material, d.occluder_material);
  EXPECT_DOUBLE_EQ(s.marker_grid_spacing_mm, d.marker_grid_spacing_mm);
  EXPECT_DOUBLE_EQ(s.marker_radius_mm, d.marker_radius_mm);
  EXPECT_DOUBLE_EQ(s.marker_plane_from_source_mm, d.marker_plane_from_source_mm);
  EXPECT_EQ(s.marker_material, d.marker_material);
  EXPECT_DOUBLE_EQ(s.platform_width_mm, d.platform_width_mm);
  EXPECT_DOUBLE_EQ(s.platform_top_below_joint_mm, d.platform_top_below_joint_mm);
  EXPECT_EQ(s.platform_material, d.platform_material);
  EXPECT_EQ(s.side, d.side);
  EXPECT_TRUE(s.motion.joint_travel_mm.isApprox(d.motion.joint_travel_mm));
  EXPECT_EQ(s.contralateral_knee.kind, d.contralateral_knee.kind);
  EXPECT_TRUE(s.contralateral_knee.offset_mm.isApprox(d.contralateral_knee.offset_mm));
  EXPECT_TRUE(s.contralateral_knee.travel_mm.isApprox(d.contralateral_knee.travel_mm));
  EXPECT_DOUBLE_EQ(s.contralateral_knee.phase, d.contralateral_knee.phase);
  EXPECT_TRUE(s.principal_point_offset_px.isApprox(d.principal_point_offset_px));
}

// joint_travel_mm moves the whole knee through the view at constant velocity, from minus half
// the travel at the first frame to plus half at the last, in the first view's camera frame
// (x right, y down, z along the beam), for a left knee as for a right one; the joint itself is
// the same.
TEST(TrialSimulator, JointTravelMovesTheKneeThroughTheView) {
  TempDir dir;
  test_support::writeText(dir.file("travel.yaml"),
                          "motion: {frames: 5, joint_travel_mm: [120, -40, 20]}\n");
  sim::TrialSimulatorSettings travelling = sim::loadSimulatorSettings(dir.file("travel.yaml"));
  sim::TrialSimulatorSettings still = travelling;
  still.motion.joint_travel_mm.setZero();
  for (const kinematics::Side side : {kinematics::Side::kRight, kinematics::Side::kLeft}) {
    travelling.side = still.side = side;
    const sim::TrialSimulator moving(travelling);
    const sim::TrialSimulator fixed(still);
    const Eigen::Vector3d travel(0.12, -0.04, 0.02);
    for (int f = 0; f < 5; ++f) {
      const sim::SimulatedFrame a = moving.truth(f);
      const sim::SimulatedFrame b = fixed.truth(f);
      const Eigen::Vector3d expected = (f / 4.0 - 0.5) * travel;
      EXPECT_TRUE((a.tibia.translation() - b.tibia.translation()).isApprox(expected, 1e-12)) << f;
      EXPECT_TRUE((a.femur.translation() - b.femur.translation()).isApprox(expected, 1e-12)) << f;
      EXPECT_TRUE(a.tibia.linear().isApprox(b.tibia.linear(), 1e-12));
      EXPECT_TRUE((a.tibia.inverse() * a.femur).isApprox(b.tibia.inverse() * b.femur, 1e-12));
    }
  }
  test_support::writeText(dir.file("bad.yaml"), "motion: {joint_travel_mm: [1, 2]}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("bad.yaml")), "joint_travel_mm");
}

// The other knee (the far leg of a gait or step-up seen laterally) is only rendered: the trial's
// truth stays the tracked knee's. It passes across the view with its travel (from the image's
// right to its left by default), adds attenuation and removes none, and carries metal only when
// implanted.
TEST(TrialSimulator, ContralateralKneePassesAcrossTheViewWithoutMovingTheTrackedOne) {
  const sim::TrialSimulatorSettings plain = smallTrial(1);
  sim::TrialSimulatorSettings natural = plain;
  natural.contralateral_knee.kind = sim::ContralateralKnee::Kind::kNatural;
  sim::TrialSimulatorSettings implanted = plain;
  implanted.contralateral_knee.kind = sim::ContralateralKnee::Kind::kImplanted;
  const sim::TrialSimulator alone(plain);
  const sim::TrialSimulator with_bone(natural);
  const sim::TrialSimulator with_metal(implanted);
  const double centre_x = 0.5 * (plain.image_width - 1);
  for (const int f : {0, 4}) {
    EXPECT_TRUE(with_metal.truth(f).tibia.isApprox(alone.truth(f).tibia, 1e-15)) << f;
    EXPECT_TRUE(with_metal.truth(f).femur.isApprox(alone.truth(f).femur, 1e-15)) << f;
    const cv::Mat base = alone.lineIntegral(f, 0);
    const cv::Mat bone = with_bone.lineIntegral(f, 0) - base;
    const cv::Mat metal = with_metal.lineIntegral(f, 0) - with_bone.lineIntegral(f, 0);
    double lowest = 0.0;
    cv::minMaxLoc(bone, &lowest);
    EXPECT_GT(lowest, -1e-6) << f;
    EXPECT_GT(cv::countNonZero(bone > 0.5), 0.05 * bone.total()) << f;  // a leg across the view
    double deepest = 0.0;
    cv::minMaxLoc(metal, nullptr, &deepest);
    EXPECT_GT(deepest, 5.0) << f;  // centimetres of implant metal seen edge-on
    // Where the other knee's metal lies across the image: right of the centre at the first
    // frame, left of it at the last (travel_mm -250 mm across, magnified about 1.46x).
    const cv::Moments m = cv::moments(cv::Mat(metal > 1.0), true);
    ASSERT_GT(m.m00, 0.0) << f;
    const double metal_x = m.m10 / m.m00 - centre_x;
    if (f == 0) {
      EXPECT_GT(metal_x, 150.0);
    } else {
      EXPECT_LT(metal_x, -150.0);
    }
  }

  TempDir dir;
  test_support::writeText(dir.file("other.yaml"),
                          "contralateral_knee: {kind: implanted, offset_mm: [10, 20, -200], "
                          "travel_mm: [100, 0, 5], phase: 0.25}\n");
  const sim::ContralateralKnee read =
      sim::loadSimulatorSettings(dir.file("other.yaml")).contralateral_knee;
  EXPECT_EQ(read.kind, sim::ContralateralKnee::Kind::kImplanted);
  EXPECT_TRUE(read.offset_mm.isApprox(Eigen::Vector3d(10, 20, -200)));
  EXPECT_TRUE(read.travel_mm.isApprox(Eigen::Vector3d(100, 0, 5)));
  EXPECT_DOUBLE_EQ(read.phase, 0.25);
  test_support::writeText(dir.file("kind.yaml"), "contralateral_knee: {kind: both}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("kind.yaml")), "none, natural, implanted");
  test_support::writeText(dir.file("offset.yaml"), "contralateral_knee: {offset_mm: [1, 2]}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("offset.yaml")), "offset_mm");
  test_support::writeText(dir.file("phase.yaml"), "contralateral_knee: {phase: .nan}\n");
  EXPECT_THROW_WITH(sim::TrialSimulator(sim::loadSimulatorSettings(dir.file("phase.yaml"))),
                    "contralateral_knee");
}

// A calibration's principal point off the image's centre: the camera written for the tracker
// has it, and the knee, still on the central ray, projects there; out-of-image offsets are
// refused by name.
TEST(TrialSimulator, PrincipalPointOffCentreMovesTheCentralRayNotTheKnee) {
  TempDir dir;
  test_support::writeText(dir.file("pp.yaml"), "principal_point_offset_px: [40, -25]\n");
  sim::TrialSimulatorSettings off = sim::loadSimulatorSettings(dir.file("pp.yaml"));
  off.image_width = off.image_height = 512;
  off.pixel_spacing_mm = 0.76;
  off.motion.frames = 3;
  sim::TrialSimulatorSettings centred = off;
  centred.principal_point_offset_px.setZero();
  const sim::TrialSimulator a(off);
  const sim::TrialSimulator b(centred);
  const geometry::XrayCamera& camera = a.views().front().camera;
  EXPECT_DOUBLE_EQ(camera.cx(), 255.5 + 40.0);
  EXPECT_DOUBLE_EQ(camera.cy(), 255.5 - 25.0);
  EXPECT_TRUE(a.truth(1).tibia.isApprox(b.truth(1).tibia, 1e-15));
  // The implants' shadow moves with the central ray's foot.
  const auto shadow_centre = [](const cv::Mat& line_integral) {
    const cv::Moments m = cv::moments(cv::Mat(line_integral > 6.0), true);
    return Eigen::Vector2d(m.m10 / m.m00, m.m01 / m.m00);
  };
  const Eigen::Vector2d moved =
      shadow_centre(a.lineIntegral(1, 0)) - shadow_centre(b.lineIntegral(1, 0));
  EXPECT_NEAR(moved.x(), 40.0, 0.5);
  EXPECT_NEAR(moved.y(), -25.0, 0.5);
  test_support::writeText(dir.file("bad.yaml"), "principal_point_offset_px: [600, 0]\n");
  EXPECT_THROW_WITH(sim::TrialSimulator(sim::loadSimulatorSettings(dir.file("bad.yaml"))),
                    "principal_point_offset_px");
  test_support::writeText(dir.file("short.yaml"), "principal_point_offset_px: [1]\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("short.yaml")),
                    "principal_point_offset_px");
}

// A left knee is the right one mirrored: the same clinical knee coordinates frame by frame,
// components mirrored through their sagittal plane, the frame nearly a left-right flip of the
// right knee's (perspective makes it not exact), and the trial YAML saying so.
TEST(TrialSimulator, LeftKneeMirrorsTheRightOne) {
  sim::TrialSimulatorSettings right_settings = smallTrial(1);
  right_settings.motion.max_flexion_deg = 90.0;
  sim::TrialSimulatorSettings left_settings = right_settings;
  left_settings.side = kinematics::Side::kLeft;
  const sim::TrialSimulator right(right_settings);
  const sim::TrialSimulator left(left_settings);
  EXPECT_NEAR(left.implants().femoral_component.volume(),
              right.implants().femoral_component.volume(), 1e-12);
  const double right_z = right.implants().femoral_component.volumeCentroid().z();
  const double left_z = left.implants().femoral_component.volumeCentroid().z();
  EXPECT_GT(std::abs(right_z), 1e-4);  // the smaller lateral condyle moves the centroid
  EXPECT_NEAR(left_z, -right_z, 1e-12);
  for (int i = 0; i < left.frameCount(); ++i) {
    const sim::SimulatedFrame l = left.truth(i);
    const sim::SimulatedFrame r = right.truth(i);
    const auto kl = kinematics::kneeCoordinates(l.femur, l.tibia, kinematics::Side::kLeft);
    const auto kr = kinematics::kneeCoordinates(r.femur, r.tibia, kinematics::Side::kRight);
    EXPECT_NEAR(kl.flexion_rad, kr.flexion_rad, 1e-9) << i;
    EXPECT_NEAR(kl.adduction_rad, kr.adduction_rad, 1e-9) << i;
    EXPECT_NEAR(kl.internal_rotation_rad, kr.internal_rotation_rad, 1e-9) << i;
    EXPECT_NEAR(kl.z_m, kr.z_m, 1e-9) << i;
    // Anterior (bone X) points the other way across the image; superior (Y) does not.
    EXPECT_NEAR(l.tibia.linear().col(0).x(), -r.tibia.linear().col(0).x(), 1e-9) << i;
    EXPECT_NEAR(l.tibia.linear().col(1).y(), r.tibia.linear().col(1).y(), 1e-9) << i;
  }
  // The rendered frames: the left one is close to the right one flipped about the image's
  // vertical axis, far from the right one as it is.
  const cv::Mat l = left.lineIntegral(3, 0);
  const cv::Mat r = right.lineIntegral(3, 0);
  cv::Mat flipped;
  cv::flip(r, flipped, 1);
  const double mirror_difference = cv::norm(l, flipped, cv::NORM_L1);
  EXPECT_LT(mirror_difference, 0.2 * cv::norm(l, r, cv::NORM_L1));

  TempDir dir;
  left.writeModels(dir.file("models"));
  io::saveTrialConfig(dir.file("trial.yaml"), left.trialConfig(dir.file("models")));
  const io::TrialConfig config = io::loadTrialConfig(dir.file("trial.yaml"));
  ASSERT_EQ(config.joints.size(), 1u);
  EXPECT_EQ(config.joints[0].side, kinematics::Side::kLeft);

  test_support::writeText(dir.file("side.yaml"), "side: left\n");
  EXPECT_EQ(sim::loadSimulatorSettings(dir.file("side.yaml")).side, kinematics::Side::kLeft);
  test_support::writeText(dir.file("bad_side.yaml"), "side: up\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("bad_side.yaml")), "side 'up'");
}

// An uncorrected image intensifier: the frames carry its distortion, the views say which.
TEST(TrialSimulator, LensDistortionIsLeftInTheFramesAndNamedByTheViews) {
  TempDir dir;
  test_support::writeText(dir.file("ii.yaml"),
                          "image_width: 512\nimage_height: 512\npixel_spacing_mm: 0.76\n"
                          "motion: {frames: 3}\n"
                          "lens_distortion: {model: plumb_bob, coefficients: [2, 0, 0, 0, 0]}\n");
  const sim::TrialSimulatorSettings distorted_settings =
      sim::loadSimulatorSettings(dir.file("ii.yaml"));
  sim::TrialSimulatorSettings pinhole_settings = distorted_settings;
  pinhole_settings.lens_distortion = {};
  const sim::TrialSimulator distorted(distorted_settings);
  const sim::TrialSimulator pinhole(pinhole_settings);
  EXPECT_EQ(distorted.views()[0].distortion.model, "plumb_bob");
  EXPECT_FALSE(pinhole.views()[0].distortion.distorts());
  std::mt19937_64 a(4);
  std::mt19937_64 b(4);
  const cv::Mat frame = distorted.render(1, &a).images[0];
  const cv::Mat expected = imaging::applyLensDistortion(
      pinhole.render(1, &b).images[0], pinhole.views()[0].camera, distorted.views()[0].distortion);
  EXPECT_EQ(cv::norm(frame, expected, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(frame, pinhole.render(1, &b).images[0], cv::NORM_L1), 0.0);

  test_support::writeText(dir.file("bad.yaml"),
                          "lens_distortion: {model: barrel, coefficients: [0.1]}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("bad.yaml")), "distortion model 'barrel'");
  test_support::writeText(dir.file("typo.yaml"), "lens_distortion: {modle: plumb_bob}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("typo.yaml")), "unknown key 'modle'");
}

// Regression: at deep flexion the insert's dished top is seen edge-on and its centre fan folds
// in projection; a vertex landing on a pixel's sample point once produced a line integral of
// -32 (an entry counted without its exit) and a black square in the frame.
TEST(TrialSimulator, LineIntegralIsNeverNegativeOverTheDefaultTrial) {
  const sim::TrialSimulator simulator{sim::TrialSimulatorSettings()};
  for (int i = 0; i < simulator.frameCount(); ++i) {
    double lowest = 0.0;
    cv::minMaxLoc(simulator.lineIntegral(i, 0), &lowest);
    EXPECT_GT(lowest, -0.01) << "frame " << i;  // round-off of mixed-sign anatomy terms only
  }
}

// An occluding rod (Dataset B's antenna) adds attenuation along a thin band across the view and
// leaves the bones' poses alone.
TEST(TrialSimulator, OccluderRodCrossesTheViewWithoutMovingTheBones) {
  sim::TrialSimulatorSettings plain;
  plain.motion.frames = 4;
  sim::TrialSimulatorSettings occluded = plain;
  occluded.occluder_rod_radius_mm = 2.5;
  const sim::TrialSimulator a(plain);
  const sim::TrialSimulator b(occluded);
  EXPECT_TRUE(a.truth(2).tibia.isApprox(b.truth(2).tibia));
  const cv::Mat difference = b.lineIntegral(2, 0) - a.lineIntegral(2, 0);
  double largest = 0.0;
  cv::minMaxLoc(difference, nullptr, &largest);
  // A 5 mm Co-Cr rod seen across its diameter: ~5 mm x 1/mm of line integral at its centre.
  EXPECT_GT(largest, 4.0);
  const double covered =
      cv::countNonZero(difference > 0.1) / static_cast<double>(difference.total());
  EXPECT_GT(covered, 0.005);  // a band across the view
  EXPECT_LT(covered, 0.05);   // but a thin one
  occluded.occluder_rod_radius_mm = -1.0;
  EXPECT_THROW_WITH(sim::TrialSimulator{occluded}, "occluder_rod_radius_mm");
}

// Lab clutter: a bead grid adds small spots spread over the whole field, each as deep as a
// bead's diameter of metal; a platform adds an opaque slab below a straight edge at its set
// height. Neither moves the bones.
TEST(TrialSimulator, MarkerGridAndPlatformAddLabFixedClutter) {
  sim::TrialSimulatorSettings plain;
  plain.motion.frames = 4;
  sim::TrialSimulatorSettings markers = plain;
  markers.marker_grid_spacing_mm = 30.0;
  markers.marker_radius_mm = 1.5;
  sim::TrialSimulatorSettings platform = plain;
  platform.platform_width_mm = 300.0;
  platform.platform_top_below_joint_mm = 70.0;
  const sim::TrialSimulator a(plain);
  const sim::TrialSimulator b(markers);
  const sim::TrialSimulator c(platform);
  EXPECT_TRUE(a.truth(2).femur.isApprox(b.truth(2).femur));
  EXPECT_TRUE(a.truth(2).femur.isApprox(c.truth(2).femur));

  const cv::Mat beads = b.lineIntegral(2, 0) - a.lineIntegral(2, 0);
  double deepest = 0.0;
  cv::minMaxLoc(beads, nullptr, &deepest);
  EXPECT_GT(deepest, 2.0);  // 3 mm of Co-Cr through a bead's centre, ~3 in line integral
  EXPECT_LT(deepest, 3.2);
  cv::Mat spots = beads > 0.5;
  cv::Mat labels;
  const int count = cv::connectedComponents(spots, labels, 8, CV_32S) - 1;
  // A 30 mm grid at 1150 mm from the source over the 389 mm detector: 13 x 13 beads.
  EXPECT_EQ(count, 13 * 13);

  const cv::Mat slab = c.lineIntegral(2, 0) - a.lineIntegral(2, 0);
  const geometry::XrayCamera& camera = c.views()[0].camera;
  // 70 mm below the joint centre, at 1000 mm from the source of 1200: 221 px below the image
  // centre. The slab is 300 mm deep along the diverging beam, so its edge is a ramp: rays 60 px
  // above miss it (at its far face they pass 59 mm below the centre), rays 60 px below cross all
  // of it (at its near face, 76 mm below). The edge tilts 3 deg: columns near the centre.
  const double edge_row = camera.cy() + 70.0 * 1.2 / 0.38;
  const int column = static_cast<int>(camera.cx());
  EXPECT_LT(slab.at<double>(static_cast<int>(edge_row) - 60, column), 0.01);
  EXPECT_NEAR(slab.at<double>(static_cast<int>(edge_row) + 60, column), 300.0 * 0.018, 0.2);
  EXPECT_GT(slab.at<double>(static_cast<int>(edge_row), column), 0.5);

  platform.platform_width_mm = -1.0;
  EXPECT_THROW_WITH(sim::TrialSimulator{platform}, "platform_width_mm");
  markers.marker_grid_spacing_mm = 2.0;  // not more than the beads' diameter
  EXPECT_THROW_WITH(sim::TrialSimulator{markers}, "marker_grid_spacing_mm");
  // A shorter source-detector distance leaves the default bead plane (1150 mm) beyond the
  // detector: an error only when beads are drawn.
  sim::TrialSimulatorSettings short_throw = plain;
  short_throw.principal_distance_mm = 1050.0;
  EXPECT_NO_THROW(sim::TrialSimulator{short_throw});
  short_throw.marker_grid_spacing_mm = 30.0;
  EXPECT_THROW_WITH(sim::TrialSimulator{short_throw}, "marker_plane_from_source_mm");
}

// The posterior-stabilised variant (config/robustness/posterior_stabilised.yaml) sets a box;
// a post that does not fit it is named.
TEST(TrialSimulator, PosteriorStabilisedSettingsAreReadAndChecked) {
  const auto s = sim::loadSimulatorSettings(std::string(FLUORO_SOURCE_DIR) +
                                            "/config/robustness/posterior_stabilised.yaml");
  EXPECT_TRUE(s.implants.posteriorStabilised());
  EXPECT_DOUBLE_EQ(s.implants.box_width_mm, 16.0);
  TempDir dir;
  test_support::writeText(dir.file("post.yaml"),
                          "implants: {box_width_mm: 16, post_width_mm: 18, post_height_mm: 9}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("post.yaml")), "post_width_mm");
}

// Another implant design: config/robustness/kneel_implants.yaml reads the real vendor models of
// the JointTrack Kneel study and turns them into the components' ISB frames (their meshes have
// X posterior; the tray's origin lies 3 mm below its plate).
TEST(TrialSimulator, ImplantModelsFromFilesArePlacedInTheComponentsFrames) {
  sim::TrialSimulatorSettings s = sim::loadSimulatorSettings(
      std::string(FLUORO_SOURCE_DIR) + "/config/robustness/kneel_implants.yaml");
  EXPECT_EQ(s.implant_meshes.femoral_component.path,
            test_support::sharedData("jointtrack_kneel/KR_right_7_fem.stl"));
  EXPECT_TRUE(s.implant_meshes.tibial_insert.path.empty());
  s.image_width = s.image_height = 512;
  s.pixel_spacing_mm = 0.76;
  s.motion.frames = 5;
  const sim::TrialSimulator simulator(s);
  const sim::KneeImplantSet& implants = simulator.implants();
  EXPECT_TRUE(implants.insert_generated);
  // The anterior flange (the mesh's -X) is now at +X; the condyles still point down (-Y).
  const Eigen::AlignedBox3d femur = implants.femoral_component.bounds();
  EXPECT_NEAR(femur.max().x(), 0.0422, 5e-4);
  EXPECT_NEAR(femur.min().x(), -0.0249, 5e-4);
  EXPECT_NEAR(femur.min().y(), -0.0249, 5e-4);
  // The tray's plate is at the tibia frame's origin, its stem below.
  const Eigen::AlignedBox3d tray = implants.tibial_tray.bounds();
  EXPECT_NEAR(tray.max().y(), 0.0, 1e-6);
  EXPECT_NEAR(tray.min().y(), -0.0327, 5e-4);
  EXPECT_EQ(implants.femoral_component.triangles().size(), 12412u);
  // In every frame the femoral component rests on the insert fitted to it.
  const sim::KneeContactSolver contact(implants, s.implants);
  for (int i = 0; i < simulator.frameCount(); ++i) {
    const sim::SimulatedFrame frame = simulator.truth(i);
    geometry::Pose tibia_from_femur = frame.tibia.inverse() * frame.femur;
    tibia_from_femur.translation().y() += 0.0003;
    EXPECT_FALSE(contact.collides(tibia_from_femur)) << "frame " << i;
    tibia_from_femur.translation().y() -= 0.0006;
    EXPECT_TRUE(contact.collides(tibia_from_femur)) << "frame " << i;
  }
  // The trial's models are the placed meshes.
  TempDir dir;
  simulator.writeModels(dir.file("models"));
  const geometry::Mesh written = geometry::Mesh::load(dir.file("models/tibial_tray.stl"));
  EXPECT_TRUE(written.bounds().max().isApprox(tray.max(), 1e-6));
  EXPECT_TRUE(written.bounds().min().isApprox(tray.min(), 1e-6));
}

TEST(TrialSimulator, ImplantMeshSettingsNameTheirProblems) {
  TempDir dir;
  test_support::writeText(dir.file("typo.yaml"),
                          "implant_meshes: {femoral_component: {file: a.stl}}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("typo.yaml")),
                    "implant_meshes.femoral_component: unknown key 'file'");
  test_support::writeText(dir.file("nopath.yaml"), "implant_meshes: {tibial_tray: {}}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("nopath.yaml")), "missing key 'path'");
  test_support::writeText(dir.file("quat.yaml"),
                          "implant_meshes: {tibial_tray: {path: t.stl, component_from_mesh: "
                          "{position_m: [0, 0, 0], orientation_xyzw: [0, 2, 0, 0]}}}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("quat.yaml")), "not a unit quaternion");
  test_support::writeText(dir.file("units.yaml"), "implant_meshes: {units: inch}\n");
  EXPECT_THROW_WITH(sim::loadSimulatorSettings(dir.file("units.yaml")), "inch");
  // A file that is not there is named when the simulator loads it, relative paths resolved
  // against the settings file's folder.
  test_support::writeText(dir.file("absent.yaml"),
                          "implant_meshes: {femoral_component: {path: absent.stl}}\n");
  const auto s = sim::loadSimulatorSettings(dir.file("absent.yaml"));
  EXPECT_EQ(s.implant_meshes.femoral_component.path, dir.file("absent.stl"));
  EXPECT_THROW_WITH(sim::TrialSimulator{s}, "absent.stl");
}
