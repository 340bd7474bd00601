#include "fluoro_tracker/registration/motion_prediction.h"

#include <gtest/gtest.h>

#include <vector>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/kinematics/knee_coordinates.h"

using namespace fluoro_tracker;
using geometry::Pose;
using Prediction = registration::RegistrationSettings::TrackingPrediction;

namespace {

registration::JointModel knee(int parent, int child) {
  registration::JointModel joint;
  joint.name = "knee";
  joint.parent = parent;
  joint.child = child;
  joint.type = kinematics::JointType::kKnee;
  joint.side = kinematics::Side::kRight;
  return joint;
}

kinematics::KneeCoordinates coordinates(double flexion_deg, double adduction_deg,
                                        double internal_deg, double x_mm, double y_mm,
                                        double z_mm) {
  kinematics::KneeCoordinates q;
  q.flexion_rad = geometry::degToRad(flexion_deg);
  q.adduction_rad = geometry::degToRad(adduction_deg);
  q.internal_rotation_rad = geometry::degToRad(internal_deg);
  q.x_m = x_mm / 1000.0;
  q.y_m = y_mm / 1000.0;
  q.z_m = z_mm / 1000.0;
  return q;
}

Pose femurAt(double angle_deg, double x_mm) {
  return geometry::makePose(geometry::rotationY(geometry::degToRad(angle_deg)) *
                                geometry::rotationX(geometry::degToRad(0.5 * angle_deg)),
                            Eigen::Vector3d(x_mm / 1000.0, 0.01, 1.0));
}

// The femur moves; the knee flexes 4 deg, adducts 0.5 deg and turns 2 deg inward per frame, and
// the tibia's origin moves 0.5 mm anterior, 0.3 mm down and 0.2 mm lateral.
struct TwoFrames {
  std::vector<Pose> previous;
  std::vector<Pose> current;
};
TwoFrames kneeFrames() {
  const Pose femur0 = femurAt(10.0, 0.0);
  const Pose femur1 = femurAt(13.0, 1.5);
  const auto q0 = coordinates(30.0, 1.0, 5.0, 2.0, -40.0, 1.0);
  const auto q1 = coordinates(34.0, 1.5, 7.0, 2.5, -40.3, 1.2);
  const auto side = kinematics::Side::kRight;
  return {{femur0, kinematics::tibiaFromKneeCoordinates(femur0, q0, side)},
          {femur1, kinematics::tibiaFromKneeCoordinates(femur1, q1, side)}};
}

void expectSamePose(const Pose& a, const Pose& b) {
  EXPECT_LT((a.translation() - b.translation()).norm(), 1e-9);
  EXPECT_LT(geometry::rotationAngleBetween(a.rotation(), b.rotation()), 1e-9);
}

}  // namespace

TEST(MotionPrediction, ConstantVelocityRepeatsEachBonesLastMotion) {
  const TwoFrames f = kneeFrames();
  const auto predicted = registration::predictPoses(f.previous, f.current, {knee(0, 1)},
                                                    Prediction::kConstantVelocity);
  ASSERT_EQ(predicted.size(), 2u);
  for (std::size_t b = 0; b < 2; ++b) {
    expectSamePose(predicted[b], f.current[b] * (f.previous[b].inverse() * f.current[b]));
  }
  // ... which extrapolates the joint's internal rotation too.
  const auto q = kinematics::kneeCoordinates(predicted[0], predicted[1], kinematics::Side::kRight);
  EXPECT_GT(geometry::radToDeg(q.internal_rotation_rad), 8.0);
}

TEST(MotionPrediction, JointCoordinatesExtrapolateFlexionAndTranslationsAndHoldTheOtherAngles) {
  const TwoFrames f = kneeFrames();
  const auto predicted = registration::predictPoses(f.previous, f.current, {knee(0, 1)},
                                                    Prediction::kJointCoordinates);
  ASSERT_EQ(predicted.size(), 2u);
  expectSamePose(predicted[0], f.current[0] * (f.previous[0].inverse() * f.current[0]));
  const auto q = kinematics::kneeCoordinates(predicted[0], predicted[1], kinematics::Side::kRight);
  EXPECT_NEAR(geometry::radToDeg(q.flexion_rad), 38.0, 1e-9);
  EXPECT_NEAR(geometry::radToDeg(q.adduction_rad), 1.5, 1e-9);
  EXPECT_NEAR(geometry::radToDeg(q.internal_rotation_rad), 7.0, 1e-9);
  EXPECT_NEAR(q.x_m * 1000.0, 3.0, 1e-9);
  EXPECT_NEAR(q.y_m * 1000.0, -40.6, 1e-9);
  EXPECT_NEAR(q.z_m * 1000.0, 1.4, 1e-9);
}

TEST(MotionPrediction, AChainIsPredictedParentFirstWhateverTheJointsOrder) {
  const TwoFrames f = kneeFrames();
  // A third bone hangs off the tibia as the tibia off the femur.
  const auto side = kinematics::Side::kRight;
  std::vector<Pose> previous = f.previous;
  std::vector<Pose> current = f.current;
  previous.push_back(kinematics::tibiaFromKneeCoordinates(
      previous[1], coordinates(10.0, 0.0, 2.0, 0.0, -30.0, 0.0), side));
  current.push_back(kinematics::tibiaFromKneeCoordinates(
      current[1], coordinates(12.0, 0.0, 3.0, 0.0, -30.0, 0.0), side));
  const auto predicted = registration::predictPoses(previous, current, {knee(1, 2), knee(0, 1)},
                                                    Prediction::kJointCoordinates);
  ASSERT_EQ(predicted.size(), 3u);
  const auto q = kinematics::kneeCoordinates(predicted[1], predicted[2], side);
  EXPECT_NEAR(geometry::radToDeg(q.flexion_rad), 14.0, 1e-9);
  EXPECT_NEAR(geometry::radToDeg(q.internal_rotation_rad), 3.0, 1e-9);
  const auto first = kinematics::kneeCoordinates(predicted[0], predicted[1], side);
  EXPECT_NEAR(geometry::radToDeg(first.internal_rotation_rad), 7.0, 1e-9);
}

TEST(MotionPrediction, AJointWithoutKneeCoordinatesLeavesItsChildAtConstantVelocity) {
  const TwoFrames f = kneeFrames();
  registration::JointModel shoulder = knee(0, 1);
  shoulder.type = kinematics::JointType::kGlenohumeral;
  const auto predicted =
      registration::predictPoses(f.previous, f.current, {shoulder}, Prediction::kJointCoordinates);
  expectSamePose(predicted[1], f.current[1] * (f.previous[1].inverse() * f.current[1]));
}

TEST(MotionPrediction, NamesRoundTripAndUnknownOnesAreRefused) {
  for (Prediction p : {Prediction::kConstantVelocity, Prediction::kJointCoordinates}) {
    EXPECT_EQ(registration::trackingPredictionFromName(registration::trackingPredictionName(p)), p);
  }
  EXPECT_THROW(registration::trackingPredictionFromName("kalman"), InputError);
}
