#include "fluoro_tracker/io/view_calibration.h"

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/jointtrack_calibration.h"
#include "fluoro_tracker/io/mayacam_calibration.h"
#include "text_lines.h"

namespace fluoro_tracker {
namespace io {

std::string calibrationFormatName(CalibrationFormat format) {
  return format == CalibrationFormat::kJointTrack ? "JointTrack" : "MayaCam 2.0";
}

ViewCalibration loadViewCalibration(const std::string& path, int width, int height,
                                    const std::string& frame_id) {
  const std::vector<std::string> lines = detail::readTrimmedLines(path, "calibration");
  std::string first;
  for (const std::string& line : lines) {
    if (!line.empty()) {
      first = line;
      break;
    }
  }
  ViewCalibration result;
  if (first.rfind("JT_", 0) == 0) {
    const JointTrackCalibration calibration = readJointTrackCalibration(path);
    result.format = CalibrationFormat::kJointTrack;
    result.camera = cameraFromJointTrack(calibration, width, height, frame_id);
    result.has_extrinsics = calibration.extrinsics.has_value();
    return result;
  }
  MayaCamCalibration calibration;
  try {
    calibration = readMayaCamCalibration(path);
  } catch (const InputError& e) {
    throw InputError("calibration '" + path + "' is neither JointTrack's (first line '" + first +
                     "', expected JT_INTCALIB or JT_CALIB_INT_EXT) nor MayaCam 2.0: " + e.what());
  }
  if (calibration.image_width != width || calibration.image_height != height) {
    throw InputError("calibration '" + path + "' is for " +
                     std::to_string(calibration.image_width) + "x" +
                     std::to_string(calibration.image_height) + " images, the frames are " +
                     std::to_string(width) + "x" + std::to_string(height));
  }
  result.format = CalibrationFormat::kMayaCam;
  result.camera = cameraFromMayaCam(calibration, frame_id);
  result.has_extrinsics = true;
  return result;
}

}  // namespace io
}  // namespace fluoro_tracker
