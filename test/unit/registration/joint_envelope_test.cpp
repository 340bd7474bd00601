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
  EXPECT_TRUE(
      registration::envelopeSamples(
          sphereJoint(kinematics::JointType::kGlenohumeral, Eigen::Vector3d::UnitX()), 20.0, true)
          .empty());
}
