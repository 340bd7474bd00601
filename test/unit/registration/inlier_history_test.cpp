#include "fluoro_tracker/registration/inlier_history.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "fluoro_tracker/input_error.h"

using namespace fluoro_tracker;
using registration::BoneQuality;
using registration::InlierHistory;
using registration::QualitySettings;

namespace {

std::vector<BoneQuality> fractions(std::vector<double> values) {
  std::vector<BoneQuality> quality(values.size());
  for (std::size_t b = 0; b < values.size(); ++b) {
    quality[b].contour_inlier_fraction = quality[b].offset_inlier_fraction = values[b];
  }
  return quality;
}

// The status one frame gets: `status` from the absolute thresholds, then the history's test.
std::vector<std::string> classify(InlierHistory* history, std::vector<double> values,
                                  std::vector<std::string> status) {
  history->classify(fractions(std::move(values)), &status);
  return status;
}

}  // namespace

TEST(InlierHistory, FlagsABoneWhoseInliersDropWellBelowItsRecentFrames) {
  InlierHistory history{QualitySettings()};  // drop 0.1, window 20, 3 frames
  for (double f : {0.98, 0.99, 0.97}) {
    EXPECT_EQ(classify(&history, {f, 0.9}, {"ok", "ok"}), (std::vector<std::string>{"ok", "ok"}));
  }
  EXPECT_DOUBLE_EQ(history.median(0), 0.98);
  // 0.2 below its median: a femur found on the wrong rim of a clean image. The tibia, whose
  // fractions are lower but steady, stays ok.
  EXPECT_EQ(classify(&history, {0.78, 0.9}, {"ok", "ok"}),
            (std::vector<std::string>{"suspect", "ok"}));
  // Less than the drop below: the ordinary scatter of a good frame.
  EXPECT_EQ(classify(&history, {0.9, 0.85}, {"ok", "ok"}), (std::vector<std::string>{"ok", "ok"}));
}

TEST(InlierHistory, NeedsItsMinimumOfFramesAndCanBeTurnedOff) {
  InlierHistory history{QualitySettings()};
  EXPECT_EQ(classify(&history, {0.99}, {"ok"}), std::vector<std::string>{"ok"});
  EXPECT_EQ(classify(&history, {0.99}, {"ok"}), std::vector<std::string>{"ok"});
  // Two frames of history are not yet enough to judge the third.
  EXPECT_EQ(classify(&history, {0.7}, {"ok"}), std::vector<std::string>{"ok"});
  EXPECT_EQ(classify(&history, {0.7}, {"ok"}), std::vector<std::string>{"suspect"});

  QualitySettings off;
  off.relative_inlier_drop = 0.0;
  InlierHistory unused(off);
  for (int k = 0; k < 5; ++k) classify(&unused, {0.99}, {"ok"});
  EXPECT_EQ(classify(&unused, {0.5}, {"ok"}), std::vector<std::string>{"ok"});
}

TEST(InlierHistory, LostFramesStayOutAndALastingChangeBecomesTheNewNormal) {
  QualitySettings settings;
  settings.relative_inlier_window = 6;
  InlierHistory history(settings);
  for (int k = 0; k < 6; ++k) classify(&history, {0.98}, {"ok"});
  // A blank frame: lost already, and its fraction must not drag the median down.
  EXPECT_EQ(classify(&history, {0.05}, {"lost"}), std::vector<std::string>{"lost"});
  EXPECT_DOUBLE_EQ(history.median(0), 0.98);
  // A suspect bone stays suspect (the history only adds doubt).
  EXPECT_EQ(classify(&history, {0.97}, {"suspect"}), std::vector<std::string>{"suspect"});
  // An occluder that stays: flagged at first, then (once it fills half the window) normal.
  std::vector<std::string> statuses;
  for (int k = 0; k < 6; ++k) statuses.push_back(classify(&history, {0.8}, {"ok"})[0]);
  EXPECT_EQ(statuses.front(), "suspect");
  EXPECT_EQ(statuses.back(), "ok");
  EXPECT_NEAR(history.median(0), 0.8, 1e-12);
}

TEST(InlierHistory, SettingsAreValidated) {
  QualitySettings s;
  s.relative_inlier_drop = 1.5;
  EXPECT_THROW(s.validate(), InputError);
  s = QualitySettings();
  s.relative_inlier_min_frames = 0;
  EXPECT_THROW(s.validate(), InputError);
  s = QualitySettings();
  s.relative_inlier_min_frames = s.relative_inlier_window + 1;
  EXPECT_THROW(s.validate(), InputError);
  s = QualitySettings();
  s.relative_inlier_trend_frames = 2;
  EXPECT_THROW(s.validate(), InputError);
  s.relative_inlier_trend_frames = 0;
  EXPECT_NO_THROW(s.validate());
  EXPECT_NO_THROW(QualitySettings().validate());
}

// Under a moving occluder a bone's good frames scatter by more than the fixed drop: the
// allowance widens to relative_inlier_spread robust standard deviations of its history.
TEST(InlierHistory, AllowsTheDropOfABoneWhoseFramesScatter) {
  InlierHistory history{QualitySettings()};  // drop 0.1, spread 3
  for (double f : {0.95, 0.85, 0.9, 0.95, 0.85}) classify(&history, {f, 0.99}, {"ok", "ok"});
  // Median 0.9, absolute deviations 0.05, 0.05, 0, 0.05, 0.05: 3 x 1.4826 x 0.05.
  EXPECT_NEAR(history.allowedDrop(0), 3.0 * 1.4826 * 0.05, 1e-12);
  EXPECT_DOUBLE_EQ(history.allowedDrop(1), 0.1);
  EXPECT_EQ(classify(&history, {0.72, 0.85}, {"ok", "ok"}),
            (std::vector<std::string>{"ok", "suspect"}));
  EXPECT_EQ(classify(&history, {0.6, 0.99}, {"ok", "ok"}),
            (std::vector<std::string>{"suspect", "ok"}));
}

// At its true pose a bone's fraction also drifts with the pose: the tray's outline fades into
// the soft tissue of thigh and calf as the knee flexes deeply. Against the median of its frames
// that drift was flagged frame after frame; against the trend of its last frames it is not,
// while a sudden drop on the way down still is.
TEST(InlierHistory, FollowsAFractionThatDriftsWithThePose) {
  QualitySettings median_only;
  median_only.relative_inlier_trend_frames = 0;
  InlierHistory trend{QualitySettings()};  // the last 8 frames
  InlierHistory median(median_only);
  std::vector<double> drift;
  for (int k = 0; k < 10; ++k) drift.push_back(1.0);
  for (int k = 1; k <= 8; ++k) drift.push_back(1.0 - 0.02 * k);  // down to 0.84
  int flagged_by_trend = 0;
  int flagged_by_median = 0;
  for (double f : drift) {
    flagged_by_trend += classify(&trend, {f}, {"ok"})[0] == "suspect";
    flagged_by_median += classify(&median, {f}, {"ok"})[0] == "suspect";
  }
  EXPECT_EQ(flagged_by_trend, 0);
  EXPECT_GE(flagged_by_median, 2);
  // The trend carries on to about 0.82: 0.7 is a drop, 0.8 is not.
  EXPECT_NEAR(trend.reference(0), 0.82, 1e-9);
  EXPECT_EQ(classify(&trend, {0.7}, {"ok"}), std::vector<std::string>{"suspect"});
  InlierHistory rising{QualitySettings()};
  for (int k = 0; k < 8; ++k) classify(&rising, {0.6 + 0.05 * k}, {"ok"});
  // Capped at the best frame (0.95), not carried on to 1.0.
  EXPECT_NEAR(rising.reference(0), 0.95, 1e-9);
}

// The history records and compares the fraction the status tests use: by default each sample
// counted where its bone's edge offset puts it (QualitySettings::inliers_at_edge_offset).
TEST(InlierHistory, ComparesTheFractionTheStatusTestsUse) {
  const auto at = [](double outline, double offset) {
    BoneQuality q;
    q.contour_inlier_fraction = outline;
    q.offset_inlier_fraction = offset;
    return std::vector<BoneQuality>{q};
  };
  QualitySettings where_the_outline_lies;
  where_the_outline_lies.inliers_at_edge_offset = false;
  for (const bool at_offset : {true, false}) {
    InlierHistory history(at_offset ? QualitySettings() : where_the_outline_lies);
    std::vector<std::string> status = {"ok"};
    for (int k = 0; k < 5; ++k) history.classify(at(0.95, 0.95), &status);
    // The rim moved off the outline by more than the inlier distance, the fit as good as before.
    history.classify(at(0.5, 0.93), &status);
    EXPECT_EQ(status[0], at_offset ? "ok" : "suspect");
    EXPECT_DOUBLE_EQ(history.fractionOf(at(0.5, 0.93)[0]), at_offset ? 0.93 : 0.5);
  }
}

// record() keeps the same history as classify() without testing the frame: the tracker's second
// history (counted where the outline lies) only records the frames the status history records.
TEST(InlierHistory, RecordsTheFramesClassifyWouldWithoutTestingThem) {
  InlierHistory classified{QualitySettings()};
  InlierHistory recorded{QualitySettings()};
  const std::vector<std::vector<double>> frames = {
      {0.98, 0.9}, {0.99, 0.5}, {0.97, 0.91}, {0.5, 0.9}};
  const std::vector<std::vector<std::string>> statuses = {
      {"ok", "ok"}, {"ok", "lost"}, {"ok", "ok"}, {"ok", "ok"}};
  for (std::size_t f = 0; f < frames.size(); ++f) {
    std::vector<std::string> status = statuses[f];
    classified.classify(fractions(frames[f]), &status);
    recorded.record(fractions(frames[f]), statuses[f]);
  }
  EXPECT_EQ(classify(&classified, {0.98, 0.9}, {"ok", "ok"}),
            classify(&recorded, {0.98, 0.9}, {"ok", "ok"}));
  for (std::size_t b = 0; b < 2; ++b) {
    EXPECT_DOUBLE_EQ(recorded.median(b), classified.median(b)) << b;
  }
  EXPECT_DOUBLE_EQ(recorded.median(1), 0.9);   // the lost frame's 0.5 left out
  EXPECT_DOUBLE_EQ(recorded.median(0), 0.98);  // 0.98 0.99 0.97 0.5 (suspect, recorded) 0.98
}
