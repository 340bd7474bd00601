#include "fluoro_tracker/kinematics/knee_coordinates.h"

#include <random>

#include <gtest/gtest.h>

#include "../test_support.h"
#include "fluoro_tracker/constraints/ligament_envelope.h"

using namespace fluoro_tracker;
using geometry::Pose;
using kinematics::KneeCoordinates;
using kinematics::Side;

namespace {

constexpr double kDeg = M_PI / 180.0;

Pose someFemurPose() {
  return geometry::makePose(geometry::rotationFromEulerZXY({0.3, -0.2, 1.1}),
                            Eigen::Vector3d(0.01, -0.02, 0.95));
}

}  // namespace

TEST(KneeCoordinates, RoundTripIsExactOnBothSides) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (Side side : {Side::kRight, Side::kLeft}) {
    for (int k = 0; k < 50; ++k) {
      const KneeCoordinates c{(65.0 + 75.0 * unit(rng)) * kDeg, 10.0 * unit(rng) * kDeg,
                              30.0 * unit(rng) * kDeg,          0.02 * unit(rng),
                              -0.04 + 0.01 * unit(rng),         0.005 * unit(rng)};
      const Pose femur = someFemurPose();
      const Pose tibia = kinematics::tibiaFromKneeCoordinates(femur, c, side);
      const KneeCoordinates back = kinematics::kneeCoordinates(femur, tibia, side);
      EXPECT_NEAR(back.flexion_rad, c.flexion_rad, 1e-12);
      EXPECT_NEAR(back.adduction_rad, c.adduction_rad, 1e-12);
      EXPECT_NEAR(back.internal_rotation_rad, c.internal_rotation_rad, 1e-12);
      EXPECT_NEAR(back.x_m, c.x_m, 1e-12);
      EXPECT_NEAR(back.y_m, c.y_m, 1e-12);
      EXPECT_NEAR(back.z_m, c.z_m, 1e-12);
    }
  }
}

// Poses built by hand from the ISB axes (X anterior, Y superior, Z right) give the clinical
// signs documented in the header.
TEST(KneeCoordinates, ClinicalSignsFromHandBuiltPoses) {
  const Pose femur = Pose::Identity();
  auto tibiaRotated = [](const Eigen::Matrix3d& r) {
    return geometry::makePose(r, Eigen::Vector3d(0, -0.04, 0));
  };
  // Knee bent 40 deg: the tibia swings posteriorly, its long axis (from the ankle up) tilts
  // forward: a rotation of -40 deg about Z.
  const Pose bent = tibiaRotated(geometry::rotationZ(-40.0 * kDeg));
  EXPECT_NEAR(kinematics::kneeCoordinates(femur, bent, Side::kRight).flexion_rad, 40.0 * kDeg,
              1e-12);
  EXPECT_NEAR(kinematics::kneeCoordinates(femur, bent, Side::kLeft).flexion_rad, 40.0 * kDeg,
              1e-12);
  // The tibia's long axis tilts toward +Z (the right): its distal end moves left. For a right
  // knee that is medial (varus, adduction > 0); for a left knee lateral (valgus, < 0).
  const Pose tilted = tibiaRotated(geometry::rotationX(5.0 * kDeg));
  EXPECT_NEAR(kinematics::kneeCoordinates(femur, tilted, Side::kRight).adduction_rad, 5.0 * kDeg,
              1e-12);
  EXPECT_NEAR(kinematics::kneeCoordinates(femur, tilted, Side::kLeft).adduction_rad, -5.0 * kDeg,
              1e-12);
  // The tibia turns so that its right side comes forward: +Y rotation takes Z (right) toward X
  // (anterior). Right knee: the lateral side forward, the front turns medially (internal).
  const Pose turned = tibiaRotated(geometry::rotationY(10.0 * kDeg));
  EXPECT_NEAR(kinematics::kneeCoordinates(femur, turned, Side::kRight).internal_rotation_rad,
              10.0 * kDeg, 1e-12);
  EXPECT_NEAR(kinematics::kneeCoordinates(femur, turned, Side::kLeft).internal_rotation_rad,
              -10.0 * kDeg, 1e-12);
  // Translations: the tibia's origin 2 mm anterior, 40 mm below and 3 mm to the right.
  const Pose shifted =
      geometry::makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.002, -0.04, 0.003));
  const KneeCoordinates right = kinematics::kneeCoordinates(femur, shifted, Side::kRight);
  EXPECT_NEAR(right.x_m, 0.002, 1e-12);
  EXPECT_NEAR(right.y_m, -0.04, 1e-12);
  EXPECT_NEAR(right.z_m, 0.003, 1e-12);  // lateral for a right knee
  EXPECT_NEAR(kinematics::kneeCoordinates(femur, shifted, Side::kLeft).z_m, -0.003, 1e-12);
  // The coordinates do not depend on the common frame the poses are given in.
  const Pose lab = someFemurPose();
  const KneeCoordinates moved =
      kinematics::kneeCoordinates(lab * femur, lab * shifted, Side::kRight);
  EXPECT_NEAR(moved.x_m, right.x_m, 1e-12);
  EXPECT_NEAR(moved.z_m, right.z_m, 1e-12);
}

TEST(KneeCoordinates, SidesHaveNames) {
  EXPECT_EQ(kinematics::sideFromName("left"), Side::kLeft);
  EXPECT_EQ(kinematics::sideName(Side::kRight), "right");
  EXPECT_THROW_WITH(kinematics::sideFromName("up"), "not right or left");
}

TEST(LigamentEnvelope, SpringsActOnlyOutsideTheBounds) {
  constraints::LigamentSettings s;  // knee defaults
  const double inside[6] = {60.0 * kDeg, 1.0 * kDeg, -5.0 * kDeg, 0.005, -0.04, 0.001};
  double r[6];
  constraints::ligamentResiduals(s, inside, r);
  for (double v : r) EXPECT_EQ(v, 0.0);
  const double outside[6] = {155.0 * kDeg, -5.0 * kDeg, 0.0, -0.012, 0.5, 0.0};
  constraints::ligamentResiduals(s, outside, r);
  EXPECT_NEAR(r[0], s.stiffness_per_deg * 5.0, 1e-9);   // 5 deg beyond 150 deg flexion
  EXPECT_NEAR(r[1], -s.stiffness_per_deg * 2.0, 1e-9);  // 2 deg beyond 3 deg valgus
  EXPECT_NEAR(r[3], -s.stiffness_per_mm * 2.0, 1e-9);   // 2 mm beyond -10 mm
  EXPECT_EQ(r[4], 0.0);                                 // distraction is free by default
  s.bounds[2] = {5.0, -5.0};
  EXPECT_THROW_WITH(s.validate(), "internal_rotation_deg");
}
