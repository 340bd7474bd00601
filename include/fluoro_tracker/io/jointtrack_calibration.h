#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>

#include "fluoro_tracker/geometry/xray_camera.h"

namespace fluoro_tracker {
namespace io {

// Extrinsics of a JT_CALIB_INT_EXT file, in the lab frame, millimetres.
struct JointTrackExtrinsics {
  Eigen::Vector3d source_position_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d image_normal = Eigen::Vector3d::UnitZ();  // from the image toward the source
  Eigen::Vector3d image_up = Eigen::Vector3d::UnitY();
};

// A JointTrack calibration: JT_INTCALIB (intrinsics only) or JT_CALIB_INT_EXT (intrinsics, a
// blank line, then source position, image normal and image up vector, one per line).
struct JointTrackCalibration {
  double principal_distance_mm = 0.0;
  double x_offset_mm = 0.0;  // principal point offset, + to the right
  double y_offset_mm = 0.0;  // principal point offset, + up
  double pixel_size_mm = 0.0;
  std::optional<JointTrackExtrinsics> extrinsics;
};

// Throws InputError naming the file and the line for anything malformed.
JointTrackCalibration readJointTrackCalibration(const std::string& path);
void writeJointTrackCalibration(const std::string& path, const JointTrackCalibration& calibration);

// The fluoroscope as an XrayCamera for an image of width x height pixels, following
// JointTrack's projection: column u = f·X/(−Z) + W/2 − x_offset/pixel, row counted from the top
// = H − 1 − [f·Y/(−Z) + H/2 − y_offset/pixel] in JointTrack's camera frame, which in the
// optical frame gives cx = W/2 − x_offset/pixel and cy = H/2 − 1 + y_offset/pixel.
// With extrinsics, worldFromCamera() places the optical frame in the lab frame (metres).
geometry::XrayCamera cameraFromJointTrack(const JointTrackCalibration& calibration, int width,
                                          int height,
                                          const std::string& frame_id = "fluoro_optical");

}  // namespace io
}  // namespace fluoro_tracker
