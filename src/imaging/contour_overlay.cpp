#include "fluoro_tracker/imaging/contour_overlay.h"

#include <opencv2/imgproc.hpp>

namespace fluoro_tracker {
namespace imaging {

cv::Mat drawContourOverlay(const cv::Mat& grey, const geometry::XrayCamera& camera,
                           const std::vector<const SilhouetteModel*>& models,
                           const std::vector<geometry::Pose>& poses) {
  cv::Mat eight_bit = grey;
  if (grey.depth() == CV_16U) grey.convertTo(eight_bit, CV_8U, 1.0 / 257.0);
  cv::Mat out;
  cv::cvtColor(eight_bit, out, cv::COLOR_GRAY2BGR);
  const cv::Scalar colours[] = {{0, 255, 0}, {0, 200, 255}, {255, 128, 0}, {255, 0, 255}};
  const geometry::Pose camera_from_fixed = camera.worldFromCamera().inverse();
  for (std::size_t b = 0; b < models.size() && b < poses.size(); ++b) {
    for (const auto& c : models[b]->contour(camera, camera_from_fixed * poses[b], 1.0)) {
      cv::circle(out, cv::Point2d(c.pixel.x(), c.pixel.y()), 1, colours[b % 4], cv::FILLED);
    }
  }
  return out;
}

}  // namespace imaging
}  // namespace fluoro_tracker
