#include "fluoro_tracker/geometry/pose.h"

#include <random>

#include <gtest/gtest.h>

using namespace fluoro_tracker::geometry;

TEST(Pose, EulerZXYIsRzRxRy) {
  const EulerZXY a{0.3, -0.2, 0.5};
  const Eigen::Matrix3d expected =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
      Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX()).toRotationMatrix() *
      Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_TRUE(rotationFromEulerZXY(a).isApprox(expected, 1e-12));
}

TEST(Pose, EulerZXYRoundTripOverRandomAngles) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  std::uniform_real_distribution<double> half(-M_PI / 2 + 1e-3, M_PI / 2 - 1e-3);
  for (int i = 0; i < 1000; ++i) {
    const EulerZXY a{angle(rng), half(rng), angle(rng)};
    const EulerZXY b = eulerZXYFromRotation(rotationFromEulerZXY(a));
    EXPECT_NEAR(a.z, b.z, 1e-9);
    EXPECT_NEAR(a.x, b.x, 1e-9);
    EXPECT_NEAR(a.y, b.y, 1e-9);
  }
}

TEST(Pose, EulerZXYAtGimbalLockStillReproducesTheRotation) {
  const Eigen::Matrix3d r = rotationFromEulerZXY({0.4, M_PI / 2, 0.3});
  EXPECT_TRUE(rotationFromEulerZXY(eulerZXYFromRotation(r)).isApprox(r, 1e-9));
}

TEST(Pose, EulerXYZRoundTrip) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  std::uniform_real_distribution<double> half(-M_PI / 2 + 1e-3, M_PI / 2 - 1e-3);
  for (int i = 0; i < 1000; ++i) {
    const EulerXYZ a{angle(rng), half(rng), angle(rng)};
    const Eigen::Matrix3d r = rotationFromEulerXYZ(a);
    EXPECT_TRUE(r.isApprox(rotationX(a.x) * rotationY(a.y) * rotationZ(a.z), 1e-12));
    const EulerXYZ b = eulerXYZFromRotation(r);
    EXPECT_NEAR(a.x, b.x, 1e-9);
    EXPECT_NEAR(a.y, b.y, 1e-9);
    EXPECT_NEAR(a.z, b.z, 1e-9);
  }
}

TEST(Pose, QuaternionConstructionNormalisesAndValidates) {
  const Pose p = makePose(Eigen::Quaterniond(2.0, 0.0, 0.0, 0.0), Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(p.linear().isApprox(Eigen::Matrix3d::Identity()));
  EXPECT_TRUE(isValidPose(p));
  Pose bad = p;
  bad.translation().x() = std::nan("");
  EXPECT_FALSE(isValidPose(bad));
  Pose reflected = p;
  reflected.linear() = Eigen::Vector3d(1, 1, -1).asDiagonal();
  EXPECT_FALSE(isValidPose(reflected));
}

TEST(Pose, JointTrackToOpticalFlipsYAndZAndIsSelfInverse) {
  const Pose t = jointTrackToOptical();
  // A point in front of the JointTrack camera (negative z, above the axis) lies at positive z
  // in the optical frame and above the axis means negative y (image rows grow downward).
  const Eigen::Vector3d p = t * Eigen::Vector3d(10.0, 20.0, -1000.0);
  EXPECT_TRUE(p.isApprox(Eigen::Vector3d(10.0, -20.0, 1000.0)));
  EXPECT_TRUE((t * t).matrix().isApprox(Eigen::Matrix4d::Identity()));
  EXPECT_TRUE(isValidPose(t));
}

TEST(Pose, RotationAngleBetween) {
  EXPECT_NEAR(rotationAngleBetween(rotationZ(0.1), rotationZ(0.4)), 0.3, 1e-12);
  EXPECT_NEAR(rotationAngleBetween(Eigen::Matrix3d::Identity(), rotationX(M_PI)), M_PI, 1e-9);
}

TEST(Pose, NormalizedRestoresARotationThatDrifted) {
  Pose p = makePose(rotationZ(0.3), Eigen::Vector3d(1, 2, 3));
  p.linear() *= 1.0 + 1e-5;  // round-off accumulated over many compositions
  ASSERT_FALSE(isValidPose(p));
  const Pose n = normalized(p);
  EXPECT_TRUE(isValidPose(n, 1e-12));
  EXPECT_NEAR(rotationAngleBetween(n.linear(), rotationZ(0.3)), 0.0, 1e-9);
  EXPECT_TRUE(n.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
}
