#pragma once

#include <string>

#include <Eigen/Core>

#include "fluoro_tracker/geometry/xray_camera.h"

namespace fluoro_tracker {
namespace io {

// A MayaCam 2.0 calibration as written by XMALab and read by Autoscoper: blocks headed
// "image size" (height,width), "camera matrix" (3 rows), "rotation" (3 rows) and "translation"
// (3 lines), separated by blank lines. XMALab uses OpenCV's pinhole model: a lab point X (mm)
// maps to the camera frame as R·X + t, and to pixels by the camera matrix, with y down — which
// is the ROS optical frame.
struct MayaCamCalibration {
  int image_height = 0;
  int image_width = 0;
  Eigen::Matrix3d camera_matrix = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // camera_from_lab
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
};

MayaCamCalibration readMayaCamCalibration(const std::string& path);
void writeMayaCamCalibration(const std::string& path, const MayaCamCalibration& calibration);

// worldFromCamera() of the result places the optical frame in the lab frame, in metres.
geometry::XrayCamera cameraFromMayaCam(const MayaCamCalibration& calibration,
                                       const std::string& frame_id);

}  // namespace io
}  // namespace fluoro_tracker
