#include "fluoro_tracker/io/trial_models.h"

#include <memory>

#include "../test_support.h"
#include "fluoro_tracker/registration/ligament_cost.h"
#include "fluoro_tracker/sim/implant_models.h"
#include "fluoro_tracker/sim/mesh_builder.h"

using namespace fluoro_tracker;
using test_support::TempDir;

namespace {

// A trial folder with the generated knee implants and a config naming them.
io::TrialConfig kneeTrial(const TempDir& dir, bool contact_enabled) {
  const sim::KneeImplantSet implants = sim::makeKneeImplants();
  implants.femoral_component.save(dir.file("femoral_component.stl"));
  implants.tibial_tray.save(dir.file("tibial_tray.stl"));
  implants.tibial_insert.save(dir.file("tibial_insert.stl"));
  io::TrialConfig config;
  io::BoneConfig femur;
  femur.name = "femur";
  femur.mesh = dir.file("femoral_component.stl");
  io::BoneConfig tibia;
  tibia.name = "tibia";
  tibia.mesh = dir.file("tibial_tray.stl");
  tibia.articular_mesh = dir.file("tibial_insert.stl");
  config.bones = {femur, tibia};
  io::JointConfig knee;
  knee.name = "knee";
  knee.parent = "femur";
  knee.child = "tibia";
  knee.contact.enabled = contact_enabled;
  config.joints = {knee};
  return config;
}

}  // namespace

TEST(TrialModels, BuildsImageModelsAndContactFromTheArticularMesh) {
  TempDir dir;
  const io::TrialModels models = io::loadTrialModels(kneeTrial(dir, true));
  ASSERT_EQ(models.bones.size(), 2u);
  EXPECT_EQ(models.bones[1].name, "tibia");
  // The tibia's image model is the tray; its contact surface is the insert.
  EXPECT_EQ(models.bones[1].silhouette->mesh().triangleCount(),
            sim::makeKneeImplants().tibial_tray.triangleCount());
  ASSERT_EQ(models.joints.size(), 1u);
  EXPECT_EQ(models.joints[0].name, "knee");
  EXPECT_EQ(models.joints[0].parent, 0);
  EXPECT_EQ(models.joints[0].child, 1);
  ASSERT_TRUE(models.joints[0].contact);
  // The grid covers the insert (10 mm thick) plus its margins, not the tray's 40 mm stem.
  EXPECT_LT(models.joints[0].contact->grid().box().sizes().y(), 0.035);

  const io::TrialModels without = io::loadTrialModels(kneeTrial(dir, false));
  ASSERT_EQ(without.joints.size(), 1u);
  EXPECT_FALSE(without.joints[0].contact);

  io::TrialConfig ankle = kneeTrial(dir, false);
  ankle.joints[0].type = "ankle";
  EXPECT_EQ(io::loadTrialModels(ankle).joints[0].type, kinematics::JointType::kAnkle);
  // Its springs act on dorsiflexion as stored (the knee's flexion bounds, reversed, as
  // loadTrialConfig stores an ankle's dorsiflexion_deg: [-40, 25]).
  ankle.joints[0].ligaments = constraints::LigamentSettings();
  ankle.joints[0].ligaments.bounds = {};
  ankle.joints[0].ligaments.bounds[0] = {-25.0, 40.0};
  const registration::JointModel ankle_joint = io::loadTrialModels(ankle).joints[0];
  const auto turned = [](double deg) {
    return geometry::makePose(geometry::rotationZ(deg * M_PI / 180.0), Eigen::Vector3d::Zero());
  };
  EXPECT_NEAR(ankle_joint.reportedCoordinates(geometry::Pose::Identity(), turned(30.0)).flexion_rad,
              30.0 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(ankle_joint.envelopeViolation(geometry::Pose::Identity(), turned(30.0)), 5.0, 1e-9);
  EXPECT_EQ(ankle_joint.envelopeViolation(geometry::Pose::Identity(), turned(-30.0)), 0.0);
  // A patellofemoral joint's springs act on its own coordinates (Bull et al.: lateral tilt
  // about the floating axis), though they are not the knee's of its anatomical frames.
  io::TrialConfig patella = kneeTrial(dir, false);
  patella.joints[0].type = "patellofemoral";
  patella.joints[0].ligaments = constraints::LigamentSettings();
  patella.joints[0].ligaments.bounds = {};
  patella.joints[0].ligaments.bounds[1] = {-5.0, 15.0};  // lateral_tilt_deg
  const registration::JointModel patellofemoral = io::loadTrialModels(patella).joints[0];
  kinematics::KneeCoordinates tilted;
  tilted.flexion_rad = 40.0 * M_PI / 180.0;
  tilted.adduction_rad = 20.0 * M_PI / 180.0;  // lateral tilt, 5 deg past its bound
  tilted.internal_rotation_rad = -4.0 * M_PI / 180.0;
  tilted.x_m = 0.01;
  tilted.y_m = 0.02;
  const geometry::Pose patella_pose = kinematics::distalFromJointCoordinates(
      kinematics::JointType::kPatellofemoral, geometry::Pose::Identity(), tilted,
      kinematics::Side::kRight);
  EXPECT_NEAR(patellofemoral.envelopeViolation(geometry::Pose::Identity(), patella_pose), 5.0,
              1e-9);
  // The registration's Ceres spring on the same frames: 5 deg past the bound, 10 per degree.
  std::unique_ptr<ceres::CostFunction> spring(registration::makeKneeLigamentCost(
      patellofemoral.ligaments, patellofemoral.side, patellofemoral.parentKneeFrame(),
      Eigen::Vector3d::Zero(), patella_pose * patellofemoral.childKneeFrame(),
      Eigen::Vector3d::Zero()));
  const double zero[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  const double* increments[2] = {zero, zero};
  double residuals[6];
  ASSERT_TRUE(spring->Evaluate(increments, residuals, nullptr));
  EXPECT_NEAR(residuals[1], 10.0 * 5.0, 1e-6);
  for (int k : {0, 2, 3, 4, 5}) EXPECT_EQ(residuals[k], 0.0) << "coordinate " << k;
  tilted.adduction_rad = 10.0 * M_PI / 180.0;  // inside the envelope
  EXPECT_EQ(patellofemoral.envelopeViolation(
                geometry::Pose::Identity(),
                kinematics::distalFromJointCoordinates(kinematics::JointType::kPatellofemoral,
                                                       geometry::Pose::Identity(), tilted,
                                                       kinematics::Side::kRight)),
            0.0);
  // A shoulder's joint reports the ISB's Y-X-Y angles (kinematics::jointCoordinates).
  io::TrialConfig shoulder = kneeTrial(dir, false);
  shoulder.joints[0].type = "glenohumeral";
  shoulder.joints[0].ligaments.bounds = {};
  shoulder.joints[0].ligaments.bounds[1] = {-90.0, 0.0};  // elevation_deg
  const registration::JointModel glenohumeral = io::loadTrialModels(shoulder).joints[0];
  EXPECT_EQ(glenohumeral.type, kinematics::JointType::kGlenohumeral);
  const geometry::Pose humerus = geometry::makePose(
      geometry::rotationY(0.5) * geometry::rotationX(-0.7) * geometry::rotationY(0.2),
      Eigen::Vector3d(0.0, -0.01, 0.0));
  const auto reported = glenohumeral.reportedCoordinates(geometry::Pose::Identity(), humerus);
  EXPECT_NEAR(reported.flexion_rad, 0.5, 1e-9);
  EXPECT_NEAR(reported.adduction_rad, -0.7, 1e-9);
  EXPECT_NEAR(reported.internal_rotation_rad, 0.2, 1e-9);
  // Its springs act on those angles: 0.7 rad of elevation is inside; 1.8 rad is 13.1 deg beyond.
  EXPECT_EQ(glenohumeral.envelopeViolation(geometry::Pose::Identity(), humerus), 0.0);
  const geometry::Pose raised = geometry::makePose(
      geometry::rotationY(0.5) * geometry::rotationX(-1.8) * geometry::rotationY(0.2),
      Eigen::Vector3d(0.0, -0.01, 0.0));
  EXPECT_NEAR(glenohumeral.envelopeViolation(geometry::Pose::Identity(), raised),
              1.8 * 180.0 / M_PI - 90.0, 1e-9);
  io::TrialConfig unknown = kneeTrial(dir, false);
  unknown.joints[0].type = "hip";
  EXPECT_THROW_WITH(io::loadTrialModels(unknown), "joint type 'hip'");
}

TEST(TrialModels, AnOpenArticularSurfaceIsRejectedNamingTheFile) {
  TempDir dir;
  io::TrialConfig config = kneeTrial(dir, true);
  // Drop one triangle from the insert: it is no longer closed, so it has no inside.
  const geometry::Mesh insert = geometry::Mesh::load(dir.file("tibial_insert.stl"));
  geometry::Mesh open(insert.vertices(),
                      {insert.triangles().begin(), insert.triangles().end() - 1});
  open.save(dir.file("open_insert.stl"));
  config.bones[1].articular_mesh = dir.file("open_insert.stl");
  EXPECT_THROW_WITH(io::loadTrialModels(config), "open_insert.stl");
}
