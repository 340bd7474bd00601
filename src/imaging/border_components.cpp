#include "fluoro_tracker/imaging/border_components.h"

#include <cstdint>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace fluoro_tracker {
namespace imaging {

cv::Mat componentsReachingBorder(const cv::Mat& mask, double min_area_share) {
  CV_Assert(mask.type() == CV_8U);
  cv::Mat out = cv::Mat::zeros(mask.size(), CV_8U);
  if (mask.empty()) return out;
  const bool on_border =
      cv::countNonZero(mask.row(0)) > 0 || cv::countNonZero(mask.row(mask.rows - 1)) > 0 ||
      cv::countNonZero(mask.col(0)) > 0 || cv::countNonZero(mask.col(mask.cols - 1)) > 0;
  if (!on_border) return out;
  cv::Mat labels;
  cv::Mat stats;
  cv::Mat centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<std::uint8_t> keep(static_cast<std::size_t>(count), 0);
  for (int c = 1; c < count; ++c) {
    const int x = stats.at<int>(c, cv::CC_STAT_LEFT);
    const int y = stats.at<int>(c, cv::CC_STAT_TOP);
    const int w = stats.at<int>(c, cv::CC_STAT_WIDTH);
    const int h = stats.at<int>(c, cv::CC_STAT_HEIGHT);
    const bool touches = x == 0 || y == 0 || x + w == mask.cols || y + h == mask.rows;
    keep[static_cast<std::size_t>(c)] =
        touches && stats.at<int>(c, cv::CC_STAT_AREA) >= min_area_share * mask.total();
  }
  for (int v = 0; v < mask.rows; ++v) {
    const int* label = labels.ptr<int>(v);
    std::uint8_t* o = out.ptr<std::uint8_t>(v);
    for (int u = 0; u < mask.cols; ++u) {
      if (keep[static_cast<std::size_t>(label[u])] != 0) o[u] = 255;
    }
  }
  return out;
}

}  // namespace imaging
}  // namespace fluoro_tracker
