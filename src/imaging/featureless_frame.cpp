#include "fluoro_tracker/imaging/featureless_frame.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {
namespace {

double variance(const cv::Mat& values) {
  cv::Scalar mean;
  cv::Scalar deviation;
  cv::meanStdDev(values, mean, deviation);
  return deviation[0] * deviation[0];
}

}  // namespace

double neighbourDifferenceRatio(const cv::Mat& image, int working_size_px) {
  if (image.empty()) throw InputError("featureless frame test: empty image");
  if (image.channels() != 1) {
    throw InputError("featureless frame test: expected a single-channel grey image");
  }
  cv::Mat grey;
  image.convertTo(grey, CV_64F);
  const double scale = std::min(
      1.0, std::max(working_size_px, 2) / static_cast<double>(std::max(grey.cols, grey.rows)));
  if (scale < 1.0) cv::resize(grey, grey, cv::Size(), scale, scale, cv::INTER_AREA);
  const double spread = variance(grey);
  if (!(spread > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  double differences = 0.0;
  int directions = 0;
  if (grey.cols > 1) {
    differences += variance(grey.colRange(1, grey.cols) - grey.colRange(0, grey.cols - 1));
    ++directions;
  }
  if (grey.rows > 1) {
    differences += variance(grey.rowRange(1, grey.rows) - grey.rowRange(0, grey.rows - 1));
    ++directions;
  }
  if (directions == 0) return std::numeric_limits<double>::quiet_NaN();
  return differences / directions / (2.0 * spread);
}

std::string featurelessFrame(const cv::Mat& image, double max_ratio, int working_size_px) {
  if (!(max_ratio > 0.0)) return {};
  const double ratio = neighbourDifferenceRatio(image, working_size_px);
  if (std::isnan(ratio)) return "one grey level";
  if (ratio < max_ratio) return {};
  std::ostringstream text;
  text.precision(2);
  text << std::fixed << "pixel noise only (neighbouring pixels differ as much as any two: ratio "
       << ratio << " >= " << max_ratio << ")";
  return text.str();
}

}  // namespace imaging
}  // namespace fluoro_tracker
