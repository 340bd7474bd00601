#include "fluoro_tracker/ros/view_rectifier.h"

#include <string>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/ros/conversions.h"

namespace fluoro_tracker {
namespace ros_bridge {

ViewRectifier::ViewRectifier(const sensor_msgs::CameraInfo& info)
    : camera_(fromCameraInfo(info)), info_(info) {
  const imaging::LensDistortion distortion = lensDistortion(info);
  distortion.validate("camera_info for frame '" + info.header.frame_id + "'");
  if (distortion.distorts()) maps_ = imaging::undistortionMaps(camera_, distortion);
}

cv::Mat ViewRectifier::rectify(const cv::Mat& image) const {
  if (image.cols != camera_.width() || image.rows != camera_.height()) {
    throw InputError("the image of " + camera_.frameId() + " is " + std::to_string(image.cols) +
                     "x" + std::to_string(image.rows) + " but its camera_info says " +
                     std::to_string(camera_.width()) + "x" + std::to_string(camera_.height()));
  }
  return removesDistortion() ? imaging::remapThroughLens(image, *maps_) : image;
}

bool ViewRectifier::sameCalibration(const sensor_msgs::CameraInfo& info) const {
  return info.width == info_.width && info.height == info_.height && info.K == info_.K &&
         info.D == info_.D && info.distortion_model == info_.distortion_model &&
         info.header.frame_id == info_.header.frame_id;
}

}  // namespace ros_bridge
}  // namespace fluoro_tracker
