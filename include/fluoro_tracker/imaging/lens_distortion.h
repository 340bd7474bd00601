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

// Pixel maps for cv::remap through the lens, one way or the other: where each output pixel
// samples its input. Build once per calibration (and view), use for every frame.
struct LensMaps {
  cv::Mat first;   // undistortion: CV_16SC2 integer positions; distortion: CV_32FC1 x
  cv::Mat second;  // undistortion: CV_16UC1 sub-pixel parts;  distortion: CV_32FC1 y
};

// Distorted frame -> pinhole frame: where each pinhole pixel lies in the distorted frame
// (OpenCV's undistortion maps with R the identity and the same K, in fixed point).
LensMaps undistortionMaps(const geometry::XrayCamera& camera, const LensDistortion& distortion);

// Pinhole frame -> distorted frame (the simulator's detector): where each distorted pixel's
// undistorted ray falls in the pinhole frame.
LensMaps distortionMaps(const geometry::XrayCamera& camera, const LensDistortion& distortion);

// The frame remapped through `maps`: bilinear, the border replicated so that the field's edge
// makes no step. Same size and type.
cv::Mat remapThroughLens(const cv::Mat& image, const LensMaps& maps);

// The pinhole frame as the distorting lens shows it, in one call (a copy when `distortion`
// does not distort): for a single frame; build distortionMaps() once for many.
cv::Mat applyLensDistortion(const cv::Mat& pinhole, const geometry::XrayCamera& camera,
                            const LensDistortion& distortion);

}  // namespace imaging
}  // namespace fluoro_tracker
