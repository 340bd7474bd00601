#include "fluoro_tracker/constraints/glenohumeral_springs.h"

#include <cmath>
#include <memory>

#include <ceres/cost_function.h>
#include <gtest/gtest.h>

#include "fluoro_tracker/kinematics/joint_types.h"
#include "fluoro_tracker/registration/ligament_cost.h"

using namespace fluoro_tracker;
using geometry::Pose;
using kinematics::Side;

namespace {

constexpr double kDeg = M_PI / 180.0;

// The humerus at known ISB angles (deg) and an offset (m) from the scapula, on a side.
Pose humerusAt(const Pose& scapula, double plane, double elevation, double axial,
               const Eigen::Vector3d& offset, Side side) {
  kinematics::KneeCoordinates c;
  c.flexion_rad = plane * kDeg;
  c.adduction_rad = elevation * kDeg;
  c.internal_rotation_rad = axial * kDeg;
  c.x_m = offset.x();
  c.y_m = offset.y();
  c.z_m = offset.z();
  return kinematics::distalFromJointCoordinates(kinematics::JointType::kGlenohumeral, scapula, c,
                                                side);
}

// A shoulder's envelope: elevation to 120 deg, plane -30..120 deg, axial rotation +-40 deg, the
// humeral head within 5 mm of the scapula origin laterally.
constraints::LigamentSettings shoulderEnvelope() {
  constraints::LigamentSettings s;
  s.bounds = {};
  s.bounds[0] = {-30.0, 120.0};
  s.bounds[1] = {-120.0, 0.0};
  s.bounds[2] = {-40.0, 40.0};
  s.bounds[5] = {-5.0, 5.0};
  return s;
}

const Pose kScapula = geometry::makePose(geometry::rotationZ(0.3) * geometry::rotationX(-0.2),
                                         Eigen::Vector3d(0.1, 0.2, -0.05));

}  // namespace

TEST(GlenohumeralSprings, ActOnTheIsbAnglesOnBothSides) {
  const auto s = shoulderEnvelope();
  for (const Side side : {Side::kRight, Side::kLeft}) {
    const auto violation = [&](double plane, double elevation, double axial, double z_mm) {
      return constraints::glenohumeralEnvelopeViolation(
          s, kScapula,
          humerusAt(kScapula, plane, elevation, axial, Eigen::Vector3d(0.0, -0.01, z_mm * 1e-3),
                    side),
          side);
    };
    EXPECT_NEAR(violation(60.0, -90.0, 10.0, 0.0), 0.0, 1e-12);
    EXPECT_NEAR(violation(60.0, -130.0, 10.0, 0.0), 10.0, 1e-9);  // elevated 10 deg too far
    // The plane 20 deg beyond, its spring scaled by w = 1 / (1 + sin^2 2 deg) at 90 deg.
    const double w = 1.0 / (1.0 + std::pow(std::sin(2.0 * kDeg), 2));
    EXPECT_NEAR(violation(140.0, -90.0, 10.0, 0.0), 20.0 * w, 1e-9);
    // Axial rotation 10 deg beyond, with the plane's share at this elevation (w ~ 0.999).
    EXPECT_NEAR(violation(0.0, -90.0, 50.0, 0.0), 10.0, 1e-9);
    EXPECT_NEAR(violation(60.0, -60.0, -50.0, 0.0), 10.0, 0.1);
    EXPECT_NEAR(violation(60.0, -90.0, 10.0, 7.0), 2.0, 1e-9);  // 2 mm lateral beyond
  }
}

// With the arm along the trunk the plane of elevation is undefined and the ISB reports the
// whole turn as axial rotation: the springs see the whole turn from every plane.
TEST(GlenohumeralSprings, AreContinuousThroughThePole) {
  const auto s = shoulderEnvelope();
  for (double plane : {-170.0, -90.0, 0.0, 45.0, 90.0, 179.0}) {
    for (double elevation : {0.0, -1e-7, -1e-4}) {
      // A total turn of 50 deg about the long axis: 10 deg beyond the axial bound.
      const Pose humerus =
          humerusAt(kScapula, plane, elevation, 50.0 - plane, {0.0, -0.01, 0.0}, Side::kRight);
      EXPECT_NEAR(constraints::glenohumeralEnvelopeViolation(s, kScapula, humerus, Side::kRight),
                  10.0, 1e-3)
          << "plane " << plane << ", elevation " << elevation;
    }
  }
}

// The Ceres cost: its residuals are the springs' at the linearisation, and its automatic
// derivatives are finite and match central differences, near the pole too.
TEST(GlenohumeralSprings, CeresCostHasTheSpringsAndTheirDerivatives) {
  auto s = shoulderEnvelope();
  s.bounds[1] = {-120.0, -20.0};  // the arm must be raised by 20 deg: active near the pole
  for (const double elevation : {-130.0, -60.0, -3.0, -0.5}) {
    const Pose humerus =
        humerusAt(kScapula, 70.0, elevation, 45.0, {0.001, -0.01, 0.006}, Side::kLeft);
    const Eigen::Vector3d centre(0.05, 0.1, 0.0);
    std::unique_ptr<ceres::CostFunction> cost(registration::makeGlenohumeralLigamentCost(
        s, Side::kLeft, kScapula, centre, humerus, centre));
    double parent[6] = {0, 0, 0, 0, 0, 0};
    double child[6] = {0, 0, 0, 0, 0, 0};
    double* parameters[2] = {parent, child};
    double residuals[6];
    double jacobian_parent[36];
    double jacobian_child[36];
    double* jacobians[2] = {jacobian_parent, jacobian_child};
    ASSERT_TRUE(cost->Evaluate(parameters, residuals, jacobians));
    double expected[6];
    {
      const Pose relative = kScapula.inverse() * humerus;
      Eigen::Matrix3d r = relative.linear();
      Eigen::Vector3d t = relative.translation();
      kinematics::glenohumeralAsRight(Side::kLeft, &r, &t);
      constraints::glenohumeralSpringResiduals(s, r, t, expected);
    }
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(residuals[k], expected[k], 1e-9) << k;
    EXPECT_GT(std::abs(residuals[1]) + std::abs(residuals[2]), 0.0) << "no spring is active";
    const double h = 1e-7;
    for (int bone = 0; bone < 2; ++bone) {
      for (int p = 0; p < 6; ++p) {
        double plus[6];
        double minus[6];
        parameters[bone][p] = h;
        cost->Evaluate(parameters, plus, nullptr);
        parameters[bone][p] = -h;
        cost->Evaluate(parameters, minus, nullptr);
        parameters[bone][p] = 0.0;
        for (int k = 0; k < 6; ++k) {
          const double analytic = jacobians[bone][k * 6 + p];
          ASSERT_TRUE(std::isfinite(analytic));
          EXPECT_NEAR(analytic, (plus[k] - minus[k]) / (2.0 * h), 1e-4 * (1.0 + std::abs(analytic)))
              << "elevation " << elevation << ", bone " << bone << ", parameter " << p
              << ", residual " << k;
        }
      }
    }
  }
}
