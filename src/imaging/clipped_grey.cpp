#include "fluoro_tracker/imaging/clipped_grey.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/imaging/border_components.h"

namespace fluoro_tracker {
namespace imaging {
namespace {

// Grey levels are whole numbers; a reduced scale averages a plateau's pixels to its level.
constexpr double kAtEnd = 0.5;
// The share of a region's pixels an end must hold to be looked at further (most frames' ends
// hold fewer, and cost nothing more).
constexpr double kMinEndShare = 0.01;

// Per block (`at_end`: the region's blocks wholly at an end): non-zero where they join a plateau
// that reaches the region's border, and one block around them.
cv::Mat fieldBlocks(const cv::Mat& at_end) {
  cv::Mat mask = componentsReachingBorder(at_end);
  cv::dilate(mask, mask, cv::Mat::ones(3, 3, CV_8U));
  return mask;
}

}  // namespace

ClippedGrey::ClippedGrey(const cv::Mat& region, double range, double margin_fraction) {
  CV_Assert(region.type() == CV_32F);
  if (region.empty() || !(margin_fraction > 0.0)) return;
  double lo = 0.0;
  double hi = 0.0;
  cv::minMaxLoc(region, &lo, &hi);
  if (!(hi > lo)) return;
  const double min_count = kMinEndShare * static_cast<double>(region.total());
  low_candidate_ = cv::countNonZero(region <= lo + kAtEnd) >= min_count;
  high_candidate_ = cv::countNonZero(region >= hi - kAtEnd) >= min_count;
  if (!low_candidate_ && !high_candidate_) return;
  low_ = lo;
  high_ = hi;
  margin_ = margin_fraction * range;
  region_ = region;
  if (region.cols >= 3 * kBlockPx && region.rows >= 3 * kBlockPx) {
    cv::Mat blocks;
    cv::resize(region, blocks, cv::Size(region.cols / kBlockPx, region.rows / kBlockPx), 0.0, 0.0,
               cv::INTER_AREA);
    if (low_candidate_) low_field_ = fieldBlocks(blocks <= lo + kAtEnd);
    if (high_candidate_) high_field_ = fieldBlocks(blocks >= hi - kAtEnd);
  }
}

ClippedGrey::End ClippedGrey::plateauAt(const Eigen::Vector2d& pixel) const {
  const int u = static_cast<int>(std::floor(pixel.x() + 0.5));
  const int v = static_cast<int>(std::floor(pixel.y() + 0.5));
  if (u < 1 || v < 1 || u >= region_.cols - 1 || v >= region_.rows - 1) return End::kNone;
  // A plateau's pixel is at the end itself (and most edge pixels' sides are far from both).
  const float centre = region_.at<float>(v, u);
  if (!(centre <= low_ + kAtEnd) && !(centre >= high_ - kAtEnd)) return End::kNone;
  int low = 0;
  int high = 0;
  for (int dv = -1; dv <= 1; ++dv) {
    const float* row = region_.ptr<float>(v + dv);
    for (int du = -1; du <= 1; ++du) {
      low += row[u + du] <= low_ + kAtEnd ? 1 : 0;
      high += row[u + du] >= high_ - kAtEnd ? 1 : 0;
    }
  }
  const auto in_field = [&](const cv::Mat& field) {
    if (field.empty()) return false;
    const int bu = std::min(u / kBlockPx, field.cols - 1);
    const int bv = std::min(v / kBlockPx, field.rows - 1);
    return field.at<std::uint8_t>(bv, bu) != 0;
  };
  if (low_candidate_ && low >= 5 && !in_field(low_field_)) return End::kLow;
  if (high_candidate_ && high >= 5 && !in_field(high_field_)) return End::kHigh;
  return End::kNone;
}

bool ClippedGrey::nearEnd(const Eigen::Vector2d& pixel, End end) const {
  const int u = static_cast<int>(std::floor(pixel.x() + 0.5));
  const int v = static_cast<int>(std::floor(pixel.y() + 0.5));
  if (u < 1 || v < 1 || u >= region_.cols - 1 || v >= region_.rows - 1) return false;
  double sum = 0.0;
  for (int dv = -1; dv <= 1; ++dv) {
    const float* row = region_.ptr<float>(v + dv);
    sum += static_cast<double>(row[u - 1]) + row[u] + row[u + 1];
  }
  const double mean = sum / 9.0;
  return end == End::kLow ? mean < low_ + margin_ : mean > high_ - margin_;
}

bool ClippedGrey::beside(const Eigen::Vector2d& clipped_side,
                         const Eigen::Vector2d& other_side) const {
  if (empty()) return false;
  const End end = plateauAt(clipped_side);
  return end != End::kNone && nearEnd(other_side, end);
}

bool ClippedGrey::amidNearEnd(const Eigen::Vector2d& pixel, double reach) const {
  if (empty()) return false;
  const Eigen::Vector2d around[4] = {{reach, 0.0}, {-reach, 0.0}, {0.0, reach}, {0.0, -reach}};
  for (const End end : {End::kLow, End::kHigh}) {
    if (!(end == End::kLow ? low_candidate_ : high_candidate_)) continue;
    bool all = true;
    for (const Eigen::Vector2d& step : around) all = all && nearEnd(pixel + step, end);
    if (all) return true;
  }
  return false;
}

}  // namespace imaging
}  // namespace fluoro_tracker
