#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/xray_camera.h"

namespace fluoro_tracker {
namespace imaging {

// An image intensifier's lens-like distortion (pincushion, S-distortion) in the terms of a ROS
// CameraInfo: the model's name and its coefficients in CameraInfo.D's order. The registration's
// camera is a pinhole, so a distorted frame is remapped onto the pinhole of the same K first.
struct LensDistortion {
  // plumb_bob (5 coefficients: k1 k2 p1 p2 k3), rational_polynomial (8) or equidistant (4,
  // fisheye); any name, or none, when every coefficient is zero and the model is not
  // equidistant.
  std::string model;
  std::vector<double> coefficients;

  // Whether frames differ from the pinhole's and need remapping: some coefficient is not zero,
  // or the model is equidistant (a fisheye projection even without coefficients).
  bool distorts() const;
  // Throws InputError, prefixed with `where`, for a non-finite coefficient, an unknown model
  // with non-zero coefficients, or the wrong number of coefficients for the model.
  void validate(const std::string& where) const;
};

// Where each pixel of the pinhole frame lies in the distorted frame (OpenCV's undistortion
// maps with R the identity and the same K, in OpenCV's fixed-point form): build once per
// calibration.
struct UndistortionMaps {
  cv::Mat xy;        // CV_16SC2: integer pixel positions
  cv::Mat fraction;  // CV_16UC1: their sub-pixel parts
};
UndistortionMaps undistortionMaps(const geometry::XrayCamera& camera,
                                  const LensDistortion& distortion);

// The distorted frame on the pinhole: bilinear, the border replicated so that the field's edge
// makes no step. Same size and type.
cv::Mat removeLensDistortion(const cv::Mat& distorted, const UndistortionMaps& maps);

// The pinhole frame as the distorting lens shows it (the simulator's detector): each distorted
// pixel samples the pinhole frame where its undistorted ray falls.
cv::Mat applyLensDistortion(const cv::Mat& pinhole, const geometry::XrayCamera& camera,
                            const LensDistortion& distortion);

}  // namespace imaging
}  // namespace fluoro_tracker
