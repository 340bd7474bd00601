#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/imaging/silhouette.h"

namespace fluoro_tracker {
namespace imaging {

// The frame (8- or 16-bit grey) in colour with each model's projected outer contour drawn in
// its own colour (green, orange, blue, magenta, repeating): what a user checks a result by.
// `poses` are in the fixed frame; `camera`'s worldFromCamera() places the view in it.
cv::Mat drawContourOverlay(const cv::Mat& grey, const geometry::XrayCamera& camera,
                           const std::vector<const SilhouetteModel*>& models,
                           const std::vector<geometry::Pose>& poses);

}  // namespace imaging
}  // namespace fluoro_tracker
