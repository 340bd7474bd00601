#include "fluoro_tracker/io/trial_models.h"

#include "../test_support.h"
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
  io::TrialConfig shoulder = kneeTrial(dir, false);
  shoulder.joints[0].type = "glenohumeral";
  EXPECT_THROW_WITH(io::loadTrialModels(shoulder), "glenohumeral");
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
