#pragma once

#include <string>

#include "fluoro_tracker/geometry/xray_camera.h"

namespace fluoro_tracker {
namespace io {

// The calibration files the field's tools write for a fluoroscope view: JointTrack's
// (JT_INTCALIB or JT_CALIB_INT_EXT: principal distance, principal-point offsets and pixel size)
// and MayaCam 2.0 (XMALab and Autoscoper: image size, camera matrix, pose in the lab).
enum class CalibrationFormat { kJointTrack, kMayaCam };
std::string calibrationFormatName(CalibrationFormat format);

struct ViewCalibration {
  CalibrationFormat format = CalibrationFormat::kJointTrack;
  // For the view's images; worldFromCamera() places its optical frame in the calibration's lab
  // frame (metres) when the file has extrinsics, and is the identity otherwise.
  geometry::XrayCamera camera;
  bool has_extrinsics = false;
};

// Reads `path` in whichever of the two formats it is (a first line starting "JT_" is
// JointTrack's) for frames of width x height pixels. Throws InputError naming the file for a
// malformed file, one in neither format, or (MayaCam) a calibration of another image size.
ViewCalibration loadViewCalibration(const std::string& path, int width, int height,
                                    const std::string& frame_id);

}  // namespace io
}  // namespace fluoro_tracker
