#include "fluoro_tracker/kinematics/joint_types.h"

#include <gtest/gtest.h>

#include "../test_support.h"

using namespace fluoro_tracker;
using geometry::Pose;
using kinematics::JointType;
using kinematics::Side;

namespace {

constexpr double kDeg = M_PI / 180.0;

// The types whose coordinates are the knee's of the same frames (up to the first angle's sign).
constexpr JointType kKneeCoordinateTypes[] = {JointType::kKnee,         JointType::kAnkle,
                                              JointType::kSubtalar,     JointType::kElbow,
                                              JointType::kRadiohumeral, JointType::kRadioulnar};
constexpr JointType kAllTypes[] = {JointType::kKnee,           JointType::kAnkle,
                                   JointType::kSubtalar,       JointType::kElbow,
                                   JointType::kRadiohumeral,   JointType::kRadioulnar,
                                   JointType::kPatellofemoral, JointType::kGlenohumeral};

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
  for (JointType type : {JointType::kElbow, JointType::kRadiohumeral, JointType::kRadioulnar}) {
    EXPECT_NEAR(clinical(type, front_up, Side::kRight).flexion_rad, 10.0 * kDeg, 1e-12)
        << kinematics::jointTypeName(type);
  }
  EXPECT_NEAR(clinical(JointType::kKnee, distal(geometry::rotationZ(-10.0 * kDeg)), Side::kRight)
                  .flexion_rad,
              10.0 * kDeg, 1e-12);
  // About +X (anterior) the distal segment's top tilts lateral (+Z on the right), its distal end
  // and sole medial: knee adduction (varus), inversion, elbow varus.
  const Pose distal_medial = distal(geometry::rotationX(5.0 * kDeg));
  for (JointType type : kKneeCoordinateTypes) {
    EXPECT_NEAR(clinical(type, distal_medial, Side::kRight).adduction_rad, 5.0 * kDeg, 1e-12)
        << kinematics::jointTypeName(type);
  }
  // About +Y the front (X) turns to -Z, medially on the right: internal rotation, pronation.
  const Pose front_medial = distal(geometry::rotationY(8.0 * kDeg));
  for (JointType type : kKneeCoordinateTypes) {
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
  for (JointType type : kAllTypes) {
    const auto r = kinematics::jointCoordinates(type, Pose::Identity(), right, Side::kRight);
    const auto l = kinematics::jointCoordinates(type, Pose::Identity(), left, Side::kLeft);
    EXPECT_NEAR(r.flexion_rad, l.flexion_rad, 1e-12);
    EXPECT_NEAR(r.adduction_rad, l.adduction_rad, 1e-12);
    EXPECT_NEAR(r.internal_rotation_rad, l.internal_rotation_rad, 1e-12);
    EXPECT_NEAR(r.x_m, l.x_m, 1e-12);
    EXPECT_NEAR(r.y_m, l.y_m, 1e-12);
    EXPECT_NEAR(r.z_m, l.z_m, 1e-12);
  }
}

// Every type: the distal frame built from coordinates, anywhere in space, on either side, gives
// them back.
TEST(JointTypes, EveryTypeRoundTripsThroughItsInverse) {
  const Pose proximal = geometry::makePose(geometry::rotationZ(0.4) * geometry::rotationX(-0.2),
                                           Eigen::Vector3d(0.1, 0.9, -0.3));
  for (JointType type : kAllTypes) {
    for (Side side : {Side::kRight, Side::kLeft}) {
      for (double first_deg : {-20.0, 35.0, 110.0}) {
        kinematics::KneeCoordinates c;
        c.flexion_rad = first_deg * kDeg;
        // Glenohumeral: an elevation away from 0, where the plane of elevation is defined.
        c.adduction_rad = (type == JointType::kGlenohumeral ? -40.0 : 6.0) * kDeg;
        c.internal_rotation_rad = -12.0 * kDeg;
        c.x_m = 0.004;
        c.y_m = -0.021;
        c.z_m = 0.0025;
        const Pose d = kinematics::distalFromJointCoordinates(type, proximal, c, side);
        const auto back = kinematics::jointCoordinates(type, proximal, d, side);
        const std::string what = kinematics::jointTypeName(type) + " " + std::to_string(first_deg);
        EXPECT_NEAR(back.flexion_rad, c.flexion_rad, 1e-9) << what;
        EXPECT_NEAR(back.adduction_rad, c.adduction_rad, 1e-9) << what;
        EXPECT_NEAR(back.internal_rotation_rad, c.internal_rotation_rad, 1e-9) << what;
        EXPECT_NEAR(back.x_m, c.x_m, 1e-12) << what;
        EXPECT_NEAR(back.y_m, c.y_m, 1e-12) << what;
        EXPECT_NEAR(back.z_m, c.z_m, 1e-12) << what;
      }
    }
  }
}

// Patellofemoral (Bull et al. 2002), right side, from the movements that define its signs.
TEST(JointTypes, PatellofemoralMovements) {
  const auto pf = [](const Eigen::Matrix3d& rotation, const Eigen::Vector3d& offset) {
    return kinematics::jointCoordinates(JointType::kPatellofemoral, Pose::Identity(),
                                        geometry::makePose(rotation, offset), Side::kRight);
  };
  const Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  // About -Z the patella's distal pole (-Y) moves posterior (-X): flexion, as the tibia's.
  EXPECT_LT((geometry::rotationZ(-10.0 * kDeg) * -Eigen::Vector3d::UnitY()).x(), 0.0);
  const auto flexed = pf(geometry::rotationZ(-10.0 * kDeg), origin);
  EXPECT_NEAR(flexed.flexion_rad, 10.0 * kDeg, 1e-12);
  EXPECT_NEAR(flexed.adduction_rad, 0.0, 1e-12);
  EXPECT_NEAR(flexed.internal_rotation_rad, 0.0, 1e-12);
  // About -Y the anterior surface's normal (X) turns lateral (+Z on the right): lateral tilt.
  EXPECT_GT((geometry::rotationY(-8.0 * kDeg) * Eigen::Vector3d::UnitX()).z(), 0.0);
  const auto tilted = pf(geometry::rotationY(-8.0 * kDeg), origin);
  EXPECT_NEAR(tilted.flexion_rad, 0.0, 1e-12);
  EXPECT_NEAR(tilted.adduction_rad, 8.0 * kDeg, 1e-12);
  EXPECT_NEAR(tilted.internal_rotation_rad, 0.0, 1e-12);
  // About +X the distal pole (-Y) moves medially (-Z on the right): medial rotation.
  EXPECT_LT((geometry::rotationX(6.0 * kDeg) * -Eigen::Vector3d::UnitY()).z(), 0.0);
  const auto rotated = pf(geometry::rotationX(6.0 * kDeg), origin);
  EXPECT_NEAR(rotated.flexion_rad, 0.0, 1e-12);
  EXPECT_NEAR(rotated.adduction_rad, 0.0, 1e-12);
  EXPECT_NEAR(rotated.internal_rotation_rad, 6.0 * kDeg, 1e-12);
  // Unturned, 30 mm distal, 20 mm anterior and 4 mm lateral of the femur origin.
  const auto moved = pf(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.02, -0.03, 0.004));
  EXPECT_NEAR(moved.x_m, 0.03, 1e-12);
  EXPECT_NEAR(moved.y_m, 0.02, 1e-12);
  EXPECT_NEAR(moved.z_m, 0.004, 1e-12);
  // Its e3 is not the patella's Y: the knee's coordinates of the same frames do not serve,
  // those of both frames turned by kneeFrameTurn do (the springs act on them).
  EXPECT_FALSE(kinematics::hasKneeCoordinates(JointType::kPatellofemoral));
  EXPECT_THROW_WITH(kinematics::inJointConvention(JointType::kPatellofemoral, {}), "poses");
  ASSERT_TRUE(kinematics::hasKneeFrameCoordinates(JointType::kPatellofemoral));
  const Pose& turn = kinematics::kneeFrameTurn(JointType::kPatellofemoral);
  const Pose femur = geometry::makePose(geometry::rotationX(0.3), Eigen::Vector3d(0.1, 0.0, 0.2));
  const Pose patella =
      femur * geometry::makePose(
                  geometry::rotationZ(-0.5) * geometry::rotationY(-0.1) * geometry::rotationX(0.07),
                  Eigen::Vector3d(0.02, -0.01, 0.003));
  for (const Side side : {Side::kRight, Side::kLeft}) {
    const auto own = kinematics::jointCoordinates(JointType::kPatellofemoral, femur, patella, side);
    const auto knee = kinematics::kneeCoordinates(femur * turn, patella * turn, side);
    const double sign = kinematics::firstAngleSign(JointType::kPatellofemoral);
    EXPECT_NEAR(sign * knee.flexion_rad, own.flexion_rad, 1e-12);
    EXPECT_NEAR(knee.adduction_rad, own.adduction_rad, 1e-12);
    EXPECT_NEAR(knee.internal_rotation_rad, own.internal_rotation_rad, 1e-12);
    EXPECT_NEAR(knee.x_m, own.x_m, 1e-12);
    EXPECT_NEAR(knee.y_m, own.y_m, 1e-12);
    EXPECT_NEAR(knee.z_m, own.z_m, 1e-12);
  }
  // The Grood & Suntay kinds need no turn; a shoulder's Euler angles have none.
  EXPECT_TRUE(kinematics::kneeFrameTurn(JointType::kAnkle).isApprox(Pose::Identity()));
  EXPECT_FALSE(kinematics::hasKneeFrameCoordinates(JointType::kGlenohumeral));
  EXPECT_THROW_WITH(kinematics::kneeFrameTurn(JointType::kGlenohumeral), "Euler");
}

// Glenohumeral (ISB Y-X-Y): a humerus frame built from known angles and an offset, anywhere in
// space, gives them back; on the left, from the mirrored frames.
TEST(JointTypes, GlenohumeralRoundTrip) {
  const Pose scapula = geometry::makePose(geometry::rotationZ(0.4) * geometry::rotationX(-0.2),
                                          Eigen::Vector3d(0.1, 0.9, -0.3));
  const Eigen::Matrix3d mirror = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  const Eigen::Vector3d offset(-0.004, -0.012, 0.021);
  for (double plane_deg : {-60.0, 0.0, 30.0, 90.0, 170.0}) {
    for (double elevation_deg : {-5.0, -45.0, -90.0, -150.0}) {
      for (double axial_deg : {-70.0, 0.0, 25.0}) {
        const Eigen::Matrix3d rotation = geometry::rotationY(plane_deg * kDeg) *
                                         geometry::rotationX(elevation_deg * kDeg) *
                                         geometry::rotationY(axial_deg * kDeg);
        const Pose right = scapula * geometry::makePose(rotation, offset);
        const Pose left = scapula * geometry::makePose(mirror * rotation * mirror, mirror * offset);
        for (const auto& [humerus, side] : {std::pair<Pose, Side>{right, Side::kRight},
                                            std::pair<Pose, Side>{left, Side::kLeft}}) {
          const auto c =
              kinematics::jointCoordinates(JointType::kGlenohumeral, scapula, humerus, side);
          EXPECT_NEAR(c.flexion_rad, plane_deg * kDeg, 1e-9) << plane_deg << " " << elevation_deg;
          EXPECT_NEAR(c.adduction_rad, elevation_deg * kDeg, 1e-9);
          EXPECT_NEAR(c.internal_rotation_rad, axial_deg * kDeg, 1e-9);
          EXPECT_NEAR(c.x_m, offset.x(), 1e-12);
          EXPECT_NEAR(c.y_m, offset.y(), 1e-12);
          EXPECT_NEAR(c.z_m, offset.z(), 1e-12);
        }
      }
    }
  }
}

// The ISB's movements, right side: abduction and forward flexion raise the arm with negative
// elevation in the planes 0 and 90 deg; the arm along the trunk, turned about its long axis,
// reports it all as axial rotation (the plane of elevation is undefined there), internal
// positive; a humerus flipped upside down (elevation -180 deg) likewise.
TEST(JointTypes, GlenohumeralMovements) {
  const Pose scapula = Pose::Identity();
  const auto gh = [&](const Eigen::Matrix3d& rotation) {
    return kinematics::jointCoordinates(JointType::kGlenohumeral, scapula,
                                        geometry::makePose(rotation, Eigen::Vector3d::Zero()),
                                        Side::kRight);
  };
  // Abducted 40 deg: the humerus' distal end (-Y) swings lateral (+Z on the right).
  const auto abducted = gh(geometry::rotationX(-40.0 * kDeg));
  EXPECT_GT((geometry::rotationX(-40.0 * kDeg) * -Eigen::Vector3d::UnitY()).z(), 0.0);
  EXPECT_NEAR(abducted.flexion_rad, 0.0, 1e-12);
  EXPECT_NEAR(abducted.adduction_rad, -40.0 * kDeg, 1e-12);
  // Flexed forward 40 deg: the distal end swings anterior (+X), i.e. about +Z by 40 deg.
  const auto flexed = gh(geometry::rotationZ(40.0 * kDeg));
  EXPECT_GT((geometry::rotationZ(40.0 * kDeg) * -Eigen::Vector3d::UnitY()).x(), 0.0);
  EXPECT_NEAR(flexed.flexion_rad, 90.0 * kDeg, 1e-12);
  EXPECT_NEAR(flexed.adduction_rad, -40.0 * kDeg, 1e-12);
  EXPECT_NEAR(flexed.internal_rotation_rad, -90.0 * kDeg, 1e-12);
  // Along the trunk, the front (X) turned medially (-Z): internal rotation.
  const auto internal = gh(geometry::rotationY(30.0 * kDeg));
  EXPECT_LT((geometry::rotationY(30.0 * kDeg) * Eigen::Vector3d::UnitX()).z(), 0.0);
  EXPECT_NEAR(internal.flexion_rad, 0.0, 1e-12);
  EXPECT_NEAR(internal.adduction_rad, 0.0, 1e-12);
  EXPECT_NEAR(internal.internal_rotation_rad, 30.0 * kDeg, 1e-12);
  const auto overhead = gh(geometry::rotationX(-M_PI) * geometry::rotationY(-20.0 * kDeg));
  EXPECT_NEAR(overhead.flexion_rad, 0.0, 1e-12);
  EXPECT_NEAR(std::abs(overhead.adduction_rad), M_PI, 1e-12);
  EXPECT_NEAR(overhead.internal_rotation_rad, -20.0 * kDeg, 1e-12);
  // Only from poses: the knee's coordinates lose it where the humerus' Y meets the scapula's Z.
  EXPECT_THROW_WITH(kinematics::inJointConvention(JointType::kGlenohumeral, {}), "poses");
}

TEST(JointTypes, NamesAndUnknownTypes) {
  EXPECT_EQ(kinematics::jointTypeFromName("ankle"), JointType::kAnkle);
  EXPECT_EQ(kinematics::jointTypeName(JointType::kSubtalar), "subtalar");
  EXPECT_EQ(kinematics::coordinateNames(JointType::kAnkle).angles[0], "dorsiflexion");
  EXPECT_EQ(kinematics::coordinateNames(JointType::kElbow).angles[2], "pronation");
  EXPECT_EQ(kinematics::coordinateNames(JointType::kKnee).translations[1], "superior");
  EXPECT_EQ(kinematics::jointTypeFromName("glenohumeral"), JointType::kGlenohumeral);
  EXPECT_EQ(kinematics::coordinateNames(JointType::kGlenohumeral).angles[1], "elevation");
  EXPECT_EQ(kinematics::jointTypeFromName("radioulnar"), JointType::kRadioulnar);
  EXPECT_EQ(kinematics::coordinateNames(JointType::kRadioulnar).angles[2], "pronation");
  EXPECT_EQ(kinematics::jointTypeFromName("radiohumeral"), JointType::kRadiohumeral);
  EXPECT_EQ(kinematics::jointTypeFromName("patellofemoral"), JointType::kPatellofemoral);
  EXPECT_EQ(kinematics::coordinateNames(JointType::kPatellofemoral).angles[1], "lateral_tilt");
  EXPECT_EQ(kinematics::coordinateNames(JointType::kPatellofemoral).translations[2], "lateral");
  EXPECT_THROW_WITH(kinematics::jointTypeFromName("hip"),
                    "knee, ankle, subtalar, elbow, radiohumeral, radioulnar, patellofemoral, "
                    "glenohumeral");
}
