#include "fluoro_tracker/ros/view_rectifier.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/ros/conversions.h"

namespace fluoro_tracker {
namespace ros_bridge {
namespace {

std::size_t coefficientsOf(const std::string& model) {
  if (model == "plumb_bob") return 5;
  if (model == "rational_polynomial") return 8;
  if (model == "equidistant") return 4;
  return 0;
}

}  // namespace

ViewRectifier::ViewRectifier(const sensor_msgs::CameraInfo& info)
    : camera_(fromCameraInfo(info)), info_(info) {
  const std::string where = "camera_info for frame '" + info.header.frame_id + "'";
  for (double d : info.D) {
    if (!std::isfinite(d)) throw InputError(where + " has a non-finite distortion coefficient");
  }
  const bool distorted =
      std::any_of(info.D.begin(), info.D.end(), [](double d) { return d != 0.0; });
  if (!distorted) return;
  const std::size_t expected = coefficientsOf(info.distortion_model);
  if (expected == 0) {
    throw InputError(where + " has distortion model '" + info.distortion_model +
                     "', which is not plumb_bob, rational_polynomial or equidistant");
  }
  if (info.D.size() != expected) {
    throw InputError(where + ": the " + info.distortion_model + " model has " +
                     std::to_string(expected) + " distortion coefficients, not " +
                     std::to_string(info.D.size()));
  }
  const cv::Matx33d k(info.K[0], info.K[1], info.K[2], info.K[3], info.K[4], info.K[5], info.K[6],
                      info.K[7], info.K[8]);
  const cv::Mat d(info.D, true);
  const cv::Size size(camera_.width(), camera_.height());
  // Each pixel of the pinhole frame samples the distorted frame where the lens put it.
  if (info.distortion_model == "equidistant") {
    cv::fisheye::initUndistortRectifyMap(k, d, cv::Matx33d::eye(), k, size, CV_32FC1, map_x_,
                                         map_y_);
  } else {
    cv::initUndistortRectifyMap(k, d, cv::Matx33d::eye(), k, size, CV_32FC1, map_x_, map_y_);
  }
}

cv::Mat ViewRectifier::rectify(const cv::Mat& image) const {
  if (image.cols != camera_.width() || image.rows != camera_.height()) {
    throw InputError("the image of " + camera_.frameId() + " is " + std::to_string(image.cols) +
                     "x" + std::to_string(image.rows) + " but its camera_info says " +
                     std::to_string(camera_.width()) + "x" + std::to_string(camera_.height()));
  }
  if (!removesDistortion()) return image;
  cv::Mat out;
  cv::remap(image, out, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

bool ViewRectifier::sameCalibration(const sensor_msgs::CameraInfo& info) const {
  return info.width == info_.width && info.height == info_.height && info.K == info_.K &&
         info.D == info_.D && info.distortion_model == info_.distortion_model &&
         info.header.frame_id == info_.header.frame_id;
}

}  // namespace ros_bridge
}  // namespace fluoro_tracker
