#include "fluoro_tracker/registration/evaluation_point.h"

#include <gtest/gtest.h>

#include <limits>

using fluoro_tracker::registration::EvaluationPoint;

TEST(EvaluationPoint, TellsWhetherAnyBlockMoved) {
  EvaluationPoint point({3, 1});
  double a[3] = {0.1, -0.2, 0.3};
  double b[1] = {0.5};
  const double* parameters[2] = {a, b};
  EXPECT_TRUE(point.moved(parameters));  // the first call
  EXPECT_FALSE(point.moved(parameters));
  a[2] = 0.3000001;  // the same arrays, changed in place
  EXPECT_TRUE(point.moved(parameters));
  EXPECT_FALSE(point.moved(parameters));
  b[0] = -0.5;  // the last block alone
  EXPECT_TRUE(point.moved(parameters));
  const double c[3] = {0.1, -0.2, 0.3000001};
  const double d[1] = {-0.5};
  const double* elsewhere[2] = {c, d};  // equal values in other arrays
  EXPECT_FALSE(point.moved(elsewhere));
  b[0] = std::numeric_limits<double>::quiet_NaN();  // NaN never equals itself
  EXPECT_TRUE(point.moved(parameters));
  EXPECT_TRUE(point.moved(parameters));
}
