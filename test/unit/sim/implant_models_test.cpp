#include "fluoro_tracker/sim/implant_models.h"

#include "../test_support.h"
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
