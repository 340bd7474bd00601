#include "fluoro_tracker/constraints/ligament_bundle.h"

#include <gtest/gtest.h>

#include "../test_support.h"
#include "fluoro_tracker/input_error.h"

using namespace fluoro_tracker;
using geometry::Pose;

namespace {

// A bundle from the parent's origin to a point 50 mm below the child's origin, slack to 60 mm.
constraints::LigamentBundle verticalBundle() {
  constraints::LigamentBundle b;
  b.name = "test";
  b.child_insertion_m = Eigen::Vector3d(0.0, -0.05, 0.0);
  b.slack_length_m = 0.06;
  b.stiffness_per_mm = 2.0;
  return b;
}

Pose translated(double x, double y, double z) {
  return geometry::makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(x, y, z));
}

}  // namespace

TEST(LigamentBundle, SlackUpToItsLengthThenALinearSpring) {
  const auto b = verticalBundle();
  const Pose parent = Pose::Identity();
  // Child 5 mm below the parent: insertions 55 mm apart, within the slack.
  EXPECT_NEAR(b.length(parent, translated(0, -0.005, 0)), 0.055, 1e-12);
  EXPECT_EQ(b.stretchMm(parent, translated(0, -0.005, 0)), 0.0);
  // 14 mm below: 64 mm apart, 4 mm stretched; the residual is stiffness x stretch.
  EXPECT_NEAR(b.stretchMm(parent, translated(0, -0.014, 0)), 4.0, 1e-9);
  const Eigen::Vector3d p = parent * b.parent_insertion_m;
  const Eigen::Vector3d c = translated(0, -0.014, 0) * b.child_insertion_m;
  EXPECT_NEAR(b.residual<double>(p, c), 8.0, 1e-9);
  // Moving the child sideways stretches it too (the line, not one coordinate, is bounded).
  const Pose sideways = translated(0.03, -0.005, 0.0);
  EXPECT_NEAR(b.stretchMm(parent, sideways), (std::hypot(30.0, 55.0) - 60.0), 1e-9);
  // Turning the child about its origin moves its insertion: 90 deg about z swings it aside.
  const Pose turned =
      geometry::makePose(geometry::rotationZ(geometry::degToRad(90.0)), Eigen::Vector3d::Zero());
  EXPECT_NEAR(b.length(parent, turned), 0.05, 1e-12);
  EXPECT_NEAR(constraints::maxStretchMm({b}, parent, translated(0, -0.014, 0)), 4.0, 1e-9);
  EXPECT_EQ(constraints::maxStretchMm({}, parent, translated(0, -0.014, 0)), 0.0);
}

TEST(LigamentBundle, ValidateNamesTheBundleAndField) {
  auto b = verticalBundle();
  EXPECT_NO_THROW(b.validate());
  b.slack_length_m = 0.0;
  EXPECT_THROW_WITH(b.validate(), "ligament bundle 'test': slack length must be > 0");
  b = verticalBundle();
  b.child_insertion_m.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW_WITH(b.validate(), "insertion points must be finite");
  b = verticalBundle();
  b.stiffness_per_mm = -1.0;
  EXPECT_THROW_WITH(b.validate(), "stiffness_per_mm");
  b = verticalBundle();
  b.name.clear();
  EXPECT_THROW_WITH(b.validate(), "needs a name");
}
