#include "fluoro_tracker/registration/joint_envelope.h"

#include <memory>

#include <gtest/gtest.h>

#include "fluoro_tracker/constraints/articular_contact.h"
#include "fluoro_tracker/kinematics/joint_types.h"
#include "fluoro_tracker/sim/mesh_builder.h"

using namespace fluoro_tracker;
using geometry::Pose;

namespace {

// Two spheres jointed as `type`: a 25 mm "parent" at its frame's origin and a 10 mm "child"
// 40 mm along `child_offset` from its frame's origin, so that with the frames together the
// child lies 5 mm clear of the parent. Contact between them; flexion bounded, the joint's y
// translation free (the envelope then seats the child on the parent).
registration::JointModel sphereJoint(kinematics::JointType type,
                                     const Eigen::Vector3d& child_offset) {
  const geometry::Mesh parent = sim::uvSphere(0.025, 64, 128);
  const geometry::Mesh child =
      sim::uvSphere(0.010, 32, 64)
          .transformed(geometry::makePose(Eigen::Matrix3d::Identity(), 0.040 * child_offset));
  registration::JointModel joint;
  joint.parent = 0;
  joint.child = 1;
  joint.type = type;
  joint.ligaments.bounds = {};
  joint.ligaments.bounds[0] = {0.0, 60.0};
  joint.contact = std::make_shared<constraints::ArticularContact>(parent, child,
                                                                  constraints::ContactSettings());
  return joint;
}

}  // namespace

// The envelope seats the distal bone on the proximal one along the joint's y: a tibia below its
// femur moves up (its long axis), a patella in front of its femur moves back (its anterior
// axis), whatever the flexion.
TEST(JointEnvelope, SeatsTheChildOnTheParentAlongItsOwnAxis) {
  const std::pair<kinematics::JointType, Eigen::Vector3d> cases[] = {
      {kinematics::JointType::kKnee, -Eigen::Vector3d::UnitY()},            // tibia below
      {kinematics::JointType::kPatellofemoral, Eigen::Vector3d::UnitX()}};  // patella in front
  for (const auto& [type, offset] : cases) {
    const registration::JointModel joint = sphereJoint(type, offset);
    const std::vector<Pose> samples = registration::envelopeSamples(joint, 20.0, true);
    ASSERT_EQ(samples.size(), 4u) << kinematics::jointTypeName(type);  // flexion 0, 20, 40, 60
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const double gap = joint.contact->figures(Pose::Identity(), samples[i], false).min_distance_m;
      EXPECT_LT(std::abs(gap), 5e-4) << kinematics::jointTypeName(type) << " sample " << i;
      // Seated from outside: the child's centre 35 mm from the parent's.
      EXPECT_NEAR((samples[i] * (0.040 * offset)).norm(), 0.035, 1e-3)
          << kinematics::jointTypeName(type) << " sample " << i;
    }
  }
}

// A shoulder's envelope is in its own ISB angles: the elevation swept over its bounds, the plane
// of elevation and axial rotation at the middle of theirs, with the bones' anatomical frames
// anywhere in their meshes; partners found either way round and clamped coordinates agree.
TEST(JointEnvelope, ShoulderSweepsItsElevationInItsOwnAngles) {
  registration::JointModel shoulder;
  shoulder.parent = 0;
  shoulder.child = 1;
  shoulder.type = kinematics::JointType::kGlenohumeral;
  shoulder.side = kinematics::Side::kLeft;
  shoulder.parent_anatomical =
      geometry::makePose(geometry::rotationX(0.3), Eigen::Vector3d(0.01, 0.02, -0.03));
  shoulder.child_anatomical =
      geometry::makePose(geometry::rotationZ(-0.4), Eigen::Vector3d(0.0, -0.15, 0.005));
  shoulder.ligaments.bounds = {};
  shoulder.ligaments.bounds[0] = {20.0, 60.0};    // plane of elevation
  shoulder.ligaments.bounds[1] = {-90.0, -30.0};  // elevation
  shoulder.ligaments.bounds[2] = {-10.0, 30.0};   // axial rotation
  const std::vector<Pose> samples = registration::envelopeSamples(shoulder, 30.0, true);
  ASSERT_EQ(samples.size(), 3u);
  const double expected_elevation[3] = {-30.0, -60.0, -90.0};
  const Pose scapula = Pose::Identity();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const auto c = shoulder.reportedCoordinates(scapula, samples[i]);
    EXPECT_NEAR(geometry::radToDeg(c.flexion_rad), 40.0, 1e-9) << i;
    EXPECT_NEAR(geometry::radToDeg(c.adduction_rad), expected_elevation[i], 1e-9) << i;
    EXPECT_NEAR(geometry::radToDeg(c.internal_rotation_rad), 10.0, 1e-9) << i;
    EXPECT_NEAR(c.x_m, 0.0, 1e-12);
    EXPECT_LT(shoulder.envelopeViolation(scapula, samples[i]), 1e-9) << i;  // at the bounds
    // The scapula placed from the humerus by the same coordinates is where it was.
    const Pose back = registration::jointPartner(
        shoulder, samples[i], registration::envelopeCoordinates(shoulder, scapula, samples[i]),
        false);
    EXPECT_LT((back.translation() - scapula.translation()).norm(), 1e-12) << i;
    EXPECT_LT(geometry::rotationAngleBetween(back.linear(), scapula.linear()), 1e-12) << i;
  }
  // A humerus raised 120 deg in the plane at 80 deg is moved to the envelope's edge: 90 deg of
  // elevation in the 60 deg plane.
  kinematics::KneeCoordinates raised;
  raised.flexion_rad = geometry::degToRad(80.0);
  raised.adduction_rad = geometry::degToRad(-120.0);
  const Pose humerus = registration::jointPartner(shoulder, scapula, raised, true);
  const auto clamped = registration::clampedToEnvelope(
      shoulder.ligaments, registration::envelopeCoordinates(shoulder, scapula, humerus));
  EXPECT_NEAR(geometry::radToDeg(clamped.flexion_rad), 60.0, 1e-9);
  EXPECT_NEAR(geometry::radToDeg(clamped.adduction_rad), -90.0, 1e-9);
  EXPECT_LT(shoulder.envelopeViolation(
                scapula, registration::jointPartner(shoulder, scapula, clamped, true)),
            1e-9);
}
