#include "fluoro_tracker/registration/edge_offset_filter.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace fluoro_tracker;
using registration::EdgeOffsetFilter;
using registration::EdgeOffsetTrackingSettings;

TEST(EdgeOffsetFilter, GivesNoPriorBeforeTheFirstFrame) {
  const EdgeOffsetFilter filter(EdgeOffsetTrackingSettings(), 0.5);
  EXPECT_TRUE(filter.priors(2, 1).empty());
}

// One frame registered with the registrar's own prior (sd 0.5 px) measures the offset with sd
// 0.15 px: the belief is that estimate, with the two variances combined, widened by a frame's
// drift for the next frame.
TEST(EdgeOffsetFilter, CarriesEachEstimateWithItsShrunkenSpread) {
  EdgeOffsetTrackingSettings settings;
  settings.frame_sd_px = 0.15;
  settings.drift_px = 0.01;
  EdgeOffsetFilter filter(settings, 0.5);
  filter.update({{0.3}, {-0.2}}, {true, true});
  const auto priors = filter.priors(2, 1);
  ASSERT_EQ(priors.size(), 2u);
  ASSERT_EQ(priors[0].size(), 1u);
  EXPECT_DOUBLE_EQ(priors[0][0].mean_px, 0.3);
  EXPECT_DOUBLE_EQ(priors[1][0].mean_px, -0.2);
  const double posterior = 1.0 / (1.0 / 0.25 + 1.0 / 0.0225);
  EXPECT_NEAR(priors[0][0].sigma_px, std::sqrt(posterior + 0.0001), 1e-12);

  // Frame after frame the spread settles where drift and measurement balance, well below one
  // frame's own.
  for (int k = 0; k < 200; ++k) filter.update({{0.3}, {-0.2}}, {true, true});
  const double settled = filter.priors(2, 1)[0][0].sigma_px;
  EXPECT_LT(settled, 0.05);
  EXPECT_GT(settled, settings.drift_px);
}

// A lost bone's estimate is not taken: its belief stays, widened by the frame's drift.
TEST(EdgeOffsetFilter, KeepsALostBonesBelief) {
  EdgeOffsetTrackingSettings settings;
  settings.drift_px = 0.02;
  EdgeOffsetFilter filter(settings, 0.5);
  filter.update({{0.3}, {0.1}}, {true, true});
  const double sigma = filter.priors(2, 1)[1][0].sigma_px;
  filter.update({{0.35}, {3.0}}, {true, false});
  const auto priors = filter.priors(2, 1);
  EXPECT_DOUBLE_EQ(priors[0][0].mean_px, 0.35);
  EXPECT_DOUBLE_EQ(priors[1][0].mean_px, 0.1);
  EXPECT_NEAR(priors[1][0].sigma_px, std::hypot(sigma, settings.drift_px), 1e-12);
}

TEST(EdgeOffsetFilter, OffOrWithOtherViewsGivesNoPrior) {
  EdgeOffsetTrackingSettings off;
  off.enabled = false;
  EdgeOffsetFilter disabled(off, 0.5);
  disabled.update({{0.3}}, {true});
  EXPECT_TRUE(disabled.priors(1, 1).empty());

  EdgeOffsetFilter filter(EdgeOffsetTrackingSettings(), 0.5);
  filter.update({{0.3}}, {true});
  EXPECT_FALSE(filter.priors(1, 1).empty());
  EXPECT_TRUE(filter.priors(1, 2).empty());  // a second view appeared: start afresh
}
