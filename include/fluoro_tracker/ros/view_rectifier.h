#pragma once

#include <sensor_msgs/CameraInfo.h>

#include <optional>

#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/imaging/lens_distortion.h"

namespace fluoro_tracker {
namespace ros_bridge {

// One view's pinhole camera from its camera_info, and the removal of the lens distortion that
// the camera_info may carry (an image intensifier's pincushion and S-distortion, calibrated
// with a grid of beads). The registration's model is a pinhole, so a frame whose camera_info
// describes a distortion is remapped onto the pinhole of the same K before
// anything else sees it (imaging::undistortionMaps, built once per calibration).
// Distortion models: plumb_bob (5 coefficients), rational_polynomial (8) and equidistant (4,
// fisheye). R is taken as the identity (one camera, nothing to rectify against).
class ViewRectifier {
 public:
  // Throws InputError naming the problem: a K that fromCameraInfo rejects, an unknown
  // distortion model with non-zero coefficients, the wrong number of coefficients, or a
  // non-finite one.
  explicit ViewRectifier(const sensor_msgs::CameraInfo& info);

  const geometry::XrayCamera& camera() const { return camera_; }
  // Whether frames are remapped (LensDistortion::distorts).
  bool removesDistortion() const { return maps_.has_value(); }
  // The frame on the camera's pinhole: the image itself when there is no distortion, else a
  // remapped copy of the same size and type. Throws InputError for a frame of another size.
  cv::Mat rectify(const cv::Mat& image) const;
  // Whether `info` has the same size, K, distortion model and coefficients, so that this
  // rectifier's maps serve it as well (camera_info comes with every frame).
  bool sameCalibration(const sensor_msgs::CameraInfo& info) const;

 private:
  geometry::XrayCamera camera_;
  sensor_msgs::CameraInfo info_;
  std::optional<imaging::LensMaps> maps_;
};

}  // namespace ros_bridge
}  // namespace fluoro_tracker
