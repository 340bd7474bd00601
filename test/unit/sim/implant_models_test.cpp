#include "fluoro_tracker/sim/implant_models.h"

#include "../test_support.h"
#include "fluoro_tracker/constraints/articular_contact.h"
#include "fluoro_tracker/sim/knee_motion.h"

using namespace fluoro_tracker;

namespace {

// The femur on the tibia at this flexion alone (no axial rotation, rollback or varus-valgus),
// lowered onto the insert.
geometry::Pose flexedOnTheInsert(double flexion_deg, const sim::KneeContactSolver& contact) {
  sim::KneeMotionSettings motion;
  motion.frames = 1;
  motion.start_flexion_deg = motion.max_flexion_deg = flexion_deg;
  motion.internal_rotation_at_max_deg = 0.0;
  motion.rollback_at_max_mm = 0.0;
  motion.adduction_amplitude_deg = 0.0;
  return sim::kneePoseAt(motion, 0, contact).tibia_from_femur;
}

}  // namespace

TEST(ImplantModels, ComponentsAreClosedAndOfRealisticSize) {
  const sim::KneeImplantSet set = sim::makeKneeImplants();
  for (const auto* mesh : {&set.femoral_component, &set.tibial_tray, &set.tibial_insert}) {
    EXPECT_TRUE(mesh->topology().isClosed()) << mesh->topology().describe();
    EXPECT_EQ(mesh->topology().degenerate_triangles, 0u);
    EXPECT_GT(mesh->volume(), 0.0);
  }
  const Eigen::Vector3d femur = set.femoral_component.bounds().sizes();
  EXPECT_NEAR(femur.z(), 0.070, 0.002);  // medial-lateral width
  EXPECT_GT(femur.x(), 0.045);           // anterior-posterior depth
  EXPECT_LT(femur.x(), 0.060);
  EXPECT_GT(femur.y(), 0.050);  // flange top to distal condyles
  EXPECT_LT(femur.y(), 0.075);
  // Femoral components hold tens of cm^3 of cobalt-chrome.
  EXPECT_GT(set.femoral_component.volume(), 15e-6);
  EXPECT_LT(set.femoral_component.volume(), 80e-6);
  EXPECT_GT(set.femoral_component.triangleCount(), 5000u);

  const Eigen::AlignedBox3d tray = set.tibial_tray.bounds();
  EXPECT_NEAR(tray.sizes().z(), 0.074, 0.001);
  // The posterior cruciate notch trims the 48 mm ellipse a little in depth.
  EXPECT_GT(tray.sizes().x(), 0.044);
  EXPECT_LE(tray.sizes().x(), 0.048 + 1e-9);
  EXPECT_NEAR(tray.max().y(), 0.0, 1e-9);     // tray top at the tibia origin
  EXPECT_NEAR(tray.min().y(), -0.040, 1e-9);  // stem tip
  const Eigen::AlignedBox3d insert = set.tibial_insert.bounds();
  EXPECT_NEAR(insert.min().y(), 0.0, 1e-9);
  // 10 mm thick at the rims; the dished tracks and the eminence lie below that.
  EXPECT_LE(insert.max().y(), 0.010 + 1e-9);
  EXPECT_GT(insert.max().y(), 0.0095);
}

TEST(ImplantModels, InsertSurfaceHeightMatchesTheMesh) {
  const sim::KneeImplantDimensions d;
  const sim::KneeImplantSet set = sim::makeKneeImplants(d);
  // Every top-surface vertex of the insert mesh lies on the analytic articular surface.
  int top = 0;
  for (const auto& v : set.tibial_insert.vertices()) {
    if (v.y() < 0.004) continue;  // bottom face
    EXPECT_NEAR(v.y(), sim::insertSurfaceHeight(d, v.x(), v.z()), 1e-12);
    ++top;
  }
  EXPECT_GT(top, 500);
}

// The simulated knee is loaded: the femoral component touches the insert in every frame. Checked
// with FCL on the two meshes, 0.3 mm either way, and against the analytic articular surface.
TEST(KneeMotion, FemurRestsOnTheInsertInEveryFrame) {
  const sim::KneeImplantDimensions d;
  const sim::KneeImplantSet set = sim::makeKneeImplants(d);
  const sim::KneeContactSolver contact(set, d);
  sim::KneeMotionSettings motion;
  motion.frames = 13;  // odd: the middle frame is the deepest flexion
  double min_flexion = 1e9;
  double max_flexion = -1e9;
  for (int i = 0; i < motion.frames; ++i) {
    const sim::KneeFramePose pose = sim::kneePoseAt(motion, i, contact);
    min_flexion = std::min(min_flexion, pose.flexion_deg);
    max_flexion = std::max(max_flexion, pose.flexion_deg);
    geometry::Pose raised = pose.tibia_from_femur;
    raised.translation().y() += 0.0003;
    geometry::Pose lowered = pose.tibia_from_femur;
    lowered.translation().y() -= 0.0003;
    EXPECT_FALSE(contact.collides(raised)) << "frame " << i << ": femur penetrates the insert";
    EXPECT_TRUE(contact.collides(lowered)) << "frame " << i << ": femur floats above the insert";
    // Cross-check against the analytic articular surface: no femoral vertex below it by more
    // than the insert mesh's faceting (its flat triangles deviate from the surface by microns).
    EXPECT_GT(sim::femurInsertClearance(pose.tibia_from_femur, set, d), -2e-5) << "frame " << i;
  }
  EXPECT_NEAR(min_flexion, motion.start_flexion_deg, 1e-9);
  EXPECT_NEAR(max_flexion, motion.max_flexion_deg, 1e-9);
}

// Like a real component on its insert, each condyle rests in its own dished track: in neutral
// alignment both condyles are within 0.3 mm of the insert at every flexion angle, and the
// intercondylar region never carries the load (it clears the central eminence).
TEST(KneeMotion, BothCondylesRestInTheirTracks) {
  const sim::KneeImplantDimensions d;
  const sim::KneeImplantSet set = sim::makeKneeImplants(d);
  const sim::KneeContactSolver contact(set, d);
  for (double flexion : {0.0, 30.0, 60.0, 90.0, 120.0}) {
    const geometry::Pose tibia_from_femur = flexedOnTheInsert(flexion, contact);
    double medial = 1e9, lateral = 1e9, central = 1e9;  // smallest clearance per region (m)
    for (const auto& v : set.femoral_component.vertices()) {
      const Eigen::Vector3d p = tibia_from_femur * v;
      if (!sim::isOverInsert(d, p.x(), p.z())) continue;
      const double clearance = p.y() - sim::insertSurfaceHeight(d, p.x(), p.z());
      double& region = p.z() < -0.012 ? medial : p.z() > 0.012 ? lateral : central;
      region = std::min(region, clearance);
    }
    EXPECT_LT(medial, 3e-4) << flexion << " deg: the medial condyle is off its track";
    EXPECT_LT(lateral, 3e-4) << flexion << " deg: the lateral condyle is off its track";
    EXPECT_GT(central, 5e-4) << flexion << " deg: the intercondylar region rests on the insert";
  }
}

TEST(KneeMotion, InvalidSettingsAreNamed) {
  sim::KneeMotionSettings motion;
  motion.frames = 0;
  EXPECT_THROW_WITH(motion.validate(), "frames");
  motion = sim::KneeMotionSettings();
  motion.max_flexion_deg = 170.0;
  EXPECT_THROW_WITH(motion.validate(), "flexion");
}

// The real vendor components of the Kneel study on the generated insert fitted to them
// (config/robustness/kneel_implants.yaml: tracks 25 mm from the midline, the lateral track
// shallower by the 1.76 mm that the lateral distal condyle is higher). The design's condyles
// differ front to back (the lateral posterior condyle is the larger), so no track depth seats
// both at every angle: in every pose the femoral component rests on a condyle, and the other
// lifts off by less than 3.5 mm (0.7 mm in extension, 1.2-3.2 mm in flexion), as condyles lift
// off in real knees.
TEST(KneeMotion, TheKneelStudysComponentsRestOnTheirInsertWithBoundedLiftOff) {
  sim::KneeImplantDimensions d;
  d.width_mm = 72.0;
  d.condyle_track_mm = 25.0;
  d.lateral_condyle_offset_mm = 1.76;
  d.tray_ap_mm = 49.0;
  d.tray_ml_mm = 74.0;
  sim::ImplantMeshFiles files;
  const geometry::Pose turn = geometry::makePose(
      Eigen::Matrix3d(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY())), Eigen::Vector3d::Zero());
  files.femoral_component = {test_support::sharedData("jointtrack_kneel/KR_right_7_fem.stl"), turn};
  files.tibial_tray = {test_support::sharedData("jointtrack_kneel/KR_right_6_tib.stl"),
                       geometry::makePose(turn.linear(), Eigen::Vector3d(0.0, -0.003, 0.0))};
  const sim::KneeImplantSet set = sim::makeKneeImplants(d, files);
  const sim::KneeContactSolver contact(set, d);
  for (double flexion : {0.0, 30.0, 60.0, 90.0, 120.0}) {
    const geometry::Pose tibia_from_femur = flexedOnTheInsert(flexion, contact);
    double medial = 1e9, lateral = 1e9;  // smallest clearance per condyle (m)
    for (const auto& v : set.femoral_component.vertices()) {
      const Eigen::Vector3d p = tibia_from_femur * v;
      if (!sim::isOverInsert(d, p.x(), p.z()) || std::abs(p.z()) < 0.012) continue;
      double& region = p.z() < 0.0 ? medial : lateral;
      region = std::min(region, p.y() - sim::insertSurfaceHeight(d, p.x(), p.z()));
    }
    EXPECT_LT(std::min(medial, lateral), 5e-5) << flexion << " deg: neither condyle touches";
    EXPECT_LT(std::max(medial, lateral), 3.5e-3) << flexion << " deg: a condyle lifts off too far";
    EXPECT_GT(std::min(medial, lateral), -5e-5) << flexion << " deg: a condyle penetrates";
  }
}

namespace {

sim::KneeImplantDimensions posteriorStabilised() {
  sim::KneeImplantDimensions d;
  d.box_width_mm = 16.0;
  return d;
}

// Whether the femur, moved this far medial-lateral (tibia frame z) and lifted this much from its
// pose on the insert, still collides with the insert.
bool collidesShifted(const sim::KneeContactSolver& contact, geometry::Pose tibia_from_femur,
                     double shift_m, double lift_m) {
  tibia_from_femur.translation().z() += shift_m;
  tibia_from_femur.translation().y() += lift_m;
  return contact.collides(tibia_from_femur);
}

// The posterior-stabilised design and the cruciate-retaining default side by side, each with
// its contact solver (which refers to its implants: built in place).
class PosteriorStabilisedKnee : public ::testing::Test {
 protected:
  const sim::KneeImplantDimensions d = posteriorStabilised();
  const sim::KneeImplantSet set = sim::makeKneeImplants(d);
  const sim::KneeContactSolver contact{set, d};
  const sim::KneeImplantDimensions cr_dimensions;
  const sim::KneeImplantSet cr_set = sim::makeKneeImplants(cr_dimensions);
  const sim::KneeContactSolver cr_contact{cr_set, cr_dimensions};
};

}  // namespace

// The posterior-stabilised design: closed parts, an open box between the condyles from
// kBoxStartDeg on, and the post standing clear of the dished surface under it.
TEST(ImplantModels, PosteriorStabilisedComponentsHaveABoxAndAPost) {
  const sim::KneeImplantDimensions d = posteriorStabilised();
  const sim::KneeImplantSet set = sim::makeKneeImplants(d);
  const sim::KneeImplantSet cruciate_retaining = sim::makeKneeImplants();
  for (const auto* mesh : {&set.femoral_component, &set.tibial_insert}) {
    EXPECT_TRUE(mesh->topology().isClosed()) << mesh->topology().describe();
    EXPECT_EQ(mesh->topology().degenerate_triangles, 0u);
    EXPECT_GT(mesh->volume(), 0.0);
  }
  // One surface, as a vendor's model is: written and read back (welding shared vertices, as
  // track_bag reads the trial's models) it is still closed and two-manifold.
  const test_support::TempDir dir;
  set.femoral_component.save(dir.file("femoral_component.stl"));
  const geometry::Mesh reloaded = geometry::Mesh::load(dir.file("femoral_component.stl"));
  EXPECT_NEAR(reloaded.volume(), set.femoral_component.volume(), 1e-9);
  // The box takes metal away, and the component keeps its outer size.
  EXPECT_LT(set.femoral_component.volume(), cruciate_retaining.femoral_component.volume());
  EXPECT_NEAR(set.femoral_component.bounds().sizes().z(), 0.070, 0.002);
  // No metal between the box's walls past its opening (the sagittal angle from anterior
  // through distal), and some before it (the trochlea).
  int in_box = 0, trochlea = 0;
  for (const auto& v : set.femoral_component.vertices()) {
    if (std::abs(v.z()) >= 0.5 * d.box_width_mm * 1e-3 - 1e-9) continue;
    const double phi_deg = std::atan2(-v.y(), v.x()) * 180.0 / M_PI;
    if (v.y() < 0.0 && phi_deg > sim::kBoxStartDeg + 1e-6) ++in_box;
    if (v.y() < 0.0 && phi_deg < sim::kBoxStartDeg - 1e-6) ++trochlea;
  }
  EXPECT_EQ(in_box, 0);
  EXPECT_GT(trochlea, 100);
  // The post rises 12 mm above the 10 mm rim, its base above the dished surface everywhere.
  EXPECT_NEAR(set.tibial_insert.bounds().max().y(), 0.022, 1e-9);
  for (const auto& v : set.tibial_insert.vertices()) {
    if (v.y() < 0.010 - 1e-9) continue;  // the insert itself
    EXPECT_LE(std::abs(v.z()), 0.007 + 1e-9);
    EXPECT_LE(std::abs(v.x() + 0.006), 0.005 + 1e-9);
    EXPECT_GT(v.y() - sim::insertSurfaceHeight(d, v.x(), v.z()), 1e-4);
  }
}

// The post carries no load and does not change the simulated motion: in every frame of a
// motion to 120 deg with 12 deg of axial rotation the femur rests on the insert exactly as high
// as on the cruciate-retaining one, with the post inside the box.
TEST_F(PosteriorStabilisedKnee, ThePostLeavesTheMotionAsItIs) {
  sim::KneeMotionSettings motion;
  motion.frames = 25;
  motion.max_flexion_deg = 120.0;
  motion.internal_rotation_at_max_deg = 12.0;
  for (int i = 0; i < motion.frames; ++i) {
    const geometry::Pose pose = sim::kneePoseAt(motion, i, contact).tibia_from_femur;
    const geometry::Pose cr_pose = sim::kneePoseAt(motion, i, cr_contact).tibia_from_femur;
    EXPECT_NEAR(pose.translation().y(), cr_pose.translation().y(), 2e-6) << "frame " << i;
    EXPECT_FALSE(collidesShifted(contact, pose, 0.0, 0.0003)) << "frame " << i;
  }
}

// What the post is for: a medial-lateral slide of the femur, lifted 0.3 mm off the tracks so
// that only the post can stop it, collides after the post's 1 mm of play on the
// posterior-stabilised insert, and slides freely 1.5 mm either way on the cruciate-retaining one
// (up to 90 deg of flexion: past about 100 deg the post leaves the box, which has no cam).
TEST_F(PosteriorStabilisedKnee, ThePostStopsAMedialLateralSlide) {
  for (double flexion : {0.0, 30.0, 60.0, 90.0}) {
    const geometry::Pose pose = flexedOnTheInsert(flexion, contact);
    const geometry::Pose cr_pose = flexedOnTheInsert(flexion, cr_contact);
    for (double side : {-1.0, 1.0}) {
      EXPECT_FALSE(collidesShifted(contact, pose, side * 0.0008, 0.0003)) << flexion << " deg";
      EXPECT_TRUE(collidesShifted(contact, pose, side * 0.0013, 0.0003)) << flexion << " deg";
      EXPECT_FALSE(collidesShifted(cr_contact, cr_pose, side * 0.0015, 0.0003)) << flexion;
    }
  }
}

// The registration's contact measure sees the post too: the femur slid 2 mm medial-lateral
// and lifted 0.3 mm off its tracks penetrates the posterior-stabilised insert by the slide less
// the play, and the cruciate-retaining one not at all.
TEST_F(PosteriorStabilisedKnee, ArticularContactFeelsThePost) {
  constraints::ContactSettings settings;
  settings.measure = constraints::ContactMeasure::kPenetrationDepth;
  const constraints::ArticularContact ps_probe(set.femoral_component, set.tibial_insert, settings);
  const constraints::ArticularContact cr_probe(cr_set.femoral_component, cr_set.tibial_insert,
                                               settings);
  const auto slid = [](geometry::Pose tibia_from_femur, double shift_m) {
    tibia_from_femur.translation() += Eigen::Vector3d(0.0, 0.0003, shift_m);
    return tibia_from_femur.inverse();  // the femur at the origin, the tibia where it sees it
  };
  for (double flexion : {0.0, 45.0, 90.0}) {
    const geometry::Pose ps_pose = flexedOnTheInsert(flexion, contact);
    const geometry::Pose cr_pose = flexedOnTheInsert(flexion, cr_contact);
    for (double side : {-1.0, 1.0}) {
      const double ps_depth =
          ps_probe.sampledFigures(geometry::Pose::Identity(), slid(ps_pose, side * 0.002))
              .max_depth_m;
      const double cr_depth =
          cr_probe.sampledFigures(geometry::Pose::Identity(), slid(cr_pose, side * 0.002))
              .max_depth_m;
      EXPECT_NEAR(ps_depth, 0.001, 0.0003) << flexion << " deg, side " << side;
      EXPECT_EQ(cr_depth, 0.0) << flexion << " deg, side " << side;
    }
  }
}

TEST(ImplantModels, TracksBeyondTheHalfWidthAreNamed) {
  sim::KneeImplantDimensions d;
  d.condyle_track_mm = 0.5 * d.width_mm;
  EXPECT_THROW_WITH(sim::makeKneeImplants(d), "condyle_track_mm");
}

TEST(ImplantModels, InvalidPosteriorStabilisedSizesAreNamed) {
  sim::KneeImplantDimensions d = posteriorStabilised();
  d.post_width_mm = 17.0;
  EXPECT_THROW_WITH(sim::makeKneeImplants(d), "post_width_mm");
  d = posteriorStabilised();
  d.box_width_mm = 50.0;
  EXPECT_THROW_WITH(sim::makeKneeImplants(d), "box_width_mm");
  d = posteriorStabilised();
  d.post_height_mm = 0.0;
  EXPECT_THROW_WITH(d.validate(), "post_height_mm");
  d = posteriorStabilised();
  d.dish_depth_mm = 0.0;  // a flat insert: the post would stand on its surface
  EXPECT_THROW_WITH(d.validate(), "footprint");
}
