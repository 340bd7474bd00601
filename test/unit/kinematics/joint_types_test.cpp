#include "fluoro_tracker/kinematics/joint_types.h"

#include <gtest/gtest.h>

#include "../test_support.h"

using namespace fluoro_tracker;
using geometry::Pose;
using kinematics::JointType;
using kinematics::Side;

namespace {

constexpr double kDeg = M_PI / 180.0;

// The distal segment's frame, turned by `rotation` (expressed in the proximal frame) from
// coincidence with the proximal one, and offset 30 mm distally; both in ISB orientation (X
// anterior, Y proximal, Z to the right).
Pose distal(const Eigen::Matrix3d& rotation) {
  return geometry::makePose(rotation, Eigen::Vector3d(0.0, -0.03, 0.0));
}

kinematics::KneeCoordinates clinical(JointType type, const Pose& distal_pose, Side side) {
  return kinematics::inJointConvention(
      type, kinematics::kneeCoordinates(Pose::Identity(), distal_pose, side));
}

}  // namespace

// Each type's signs, from the movements that define them, for the right side.
TEST(JointTypes, SignsFollowTheirClinicalDefinitionsOnTheRight) {
  // About +Z the distal segment's front (X) turns up (Y): ankle and subtalar dorsiflexion; its
  // long axis (Y) tilts back at the top, so the distal end moves anterior: elbow flexion. The
  // tibia turning the other way (its distal end posterior) is knee flexion.
  const Pose front_up = distal(geometry::rotationZ(10.0 * kDeg));
  EXPECT_NEAR(clinical(JointType::kAnkle, front_up, Side::kRight).flexion_rad, 10.0 * kDeg, 1e-12);
  EXPECT_NEAR(clinical(JointType::kSubtalar, front_up, Side::kRight).flexion_rad, 10.0 * kDeg,
              1e-12);
  EXPECT_NEAR(clinical(JointType::kElbow, front_up, Side::kRight).flexion_rad, 10.0 * kDeg, 1e-12);
  EXPECT_NEAR(clinical(JointType::kKnee, distal(geometry::rotationZ(-10.0 * kDeg)), Side::kRight)
                  .flexion_rad,
              10.0 * kDeg, 1e-12);
  // About +X (anterior) the distal segment's top tilts lateral (+Z on the right), its distal end
  // and sole medial: knee adduction (varus), inversion, elbow varus.
  const Pose distal_medial = distal(geometry::rotationX(5.0 * kDeg));
  for (JointType type :
       {JointType::kKnee, JointType::kAnkle, JointType::kSubtalar, JointType::kElbow}) {
    EXPECT_NEAR(clinical(type, distal_medial, Side::kRight).adduction_rad, 5.0 * kDeg, 1e-12)
        << kinematics::jointTypeName(type);
  }
  // About +Y the front (X) turns to -Z, medially on the right: internal rotation, pronation.
  const Pose front_medial = distal(geometry::rotationY(8.0 * kDeg));
  for (JointType type :
       {JointType::kKnee, JointType::kAnkle, JointType::kSubtalar, JointType::kElbow}) {
    EXPECT_NEAR(clinical(type, front_medial, Side::kRight).internal_rotation_rad, 8.0 * kDeg, 1e-12)
        << kinematics::jointTypeName(type);
  }
}

// A left joint is the mirror image of a right one (reflected through the sagittal plane, Z
// negated): the same movement gives the same clinical values.
TEST(JointTypes, LeftMirrorsRight) {
  const Eigen::Matrix3d mirror = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  const Eigen::Matrix3d rotation = geometry::rotationZ(20.0 * kDeg) *
                                   geometry::rotationX(4.0 * kDeg) *
                                   geometry::rotationY(-7.0 * kDeg);
  const Pose right = geometry::makePose(rotation, Eigen::Vector3d(0.002, -0.03, 0.001));
  const Pose left =
      geometry::makePose(mirror * rotation * mirror, mirror * Eigen::Vector3d(0.002, -0.03, 0.001));
  for (JointType type :
       {JointType::kKnee, JointType::kAnkle, JointType::kSubtalar, JointType::kElbow}) {
    const auto r = clinical(type, right, Side::kRight);
    const auto l = clinical(type, left, Side::kLeft);
    EXPECT_NEAR(r.flexion_rad, l.flexion_rad, 1e-12);
    EXPECT_NEAR(r.adduction_rad, l.adduction_rad, 1e-12);
    EXPECT_NEAR(r.internal_rotation_rad, l.internal_rotation_rad, 1e-12);
    EXPECT_NEAR(r.x_m, l.x_m, 1e-12);
    EXPECT_NEAR(r.y_m, l.y_m, 1e-12);
    EXPECT_NEAR(r.z_m, l.z_m, 1e-12);
  }
}

TEST(JointTypes, NamesAndUnknownTypes) {
  EXPECT_EQ(kinematics::jointTypeFromName("ankle"), JointType::kAnkle);
  EXPECT_EQ(kinematics::jointTypeName(JointType::kSubtalar), "subtalar");
  EXPECT_EQ(kinematics::coordinateNames(JointType::kAnkle).angles[0], "dorsiflexion");
  EXPECT_EQ(kinematics::coordinateNames(JointType::kElbow).angles[2], "pronation");
  EXPECT_EQ(kinematics::coordinateNames(JointType::kKnee).translations[1], "superior");
  EXPECT_THROW_WITH(kinematics::jointTypeFromName("glenohumeral"), "knee, ankle, subtalar, elbow");
}
