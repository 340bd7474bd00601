#pragma once

#include <opencv2/core.hpp>

namespace fluoro_tracker {
namespace imaging {

// The 8-connected components of `mask` (CV_8U, non-zero: in) that reach its border, each
// covering at least `min_area_share` of its pixels, as a CV_8U mask (255 on them). What reaches
// the border of a region cut around the bones is the field's (a collimator, open air), not an
// implant's, which lies inside it.
cv::Mat componentsReachingBorder(const cv::Mat& mask, double min_area_share = 0.0);

}  // namespace imaging
}  // namespace fluoro_tracker
