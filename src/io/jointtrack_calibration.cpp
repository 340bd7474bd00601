#include "fluoro_tracker/io/jointtrack_calibration.h"

#include <fstream>
#include <iomanip>

#include "fluoro_tracker/input_error.h"
#include "text_lines.h"

namespace fluoro_tracker {
namespace io {
namespace {

constexpr char kIntrinsicHeader[] = "JT_INTCALIB";
constexpr char kFullHeader[] = "JT_CALIB_INT_EXT";

Eigen::Vector3d vectorLine(const std::vector<std::string>& lines, std::size_t index,
                           const std::string& context) {
  if (index >= lines.size()) throw InputError(context + ": missing (file ends early)");
  const auto v = detail::parseNumbers(lines[index], 3, context);
  return {v[0], v[1], v[2]};
}

}  // namespace

JointTrackCalibration readJointTrackCalibration(const std::string& path) {
  const auto lines = detail::readTrimmedLines(path, "JointTrack calibration");
  const std::string& header = lines[0];
  const bool full = header == kFullHeader;
  if (header != kIntrinsicHeader && !full) {
    throw InputError("JointTrack calibration '" + path + "': first line is '" + header +
                     "', expected JT_INTCALIB or JT_CALIB_INT_EXT");
  }
  if (lines.size() < 5) {
    throw InputError("JointTrack calibration '" + path +
                     "': expected 4 intrinsic values on lines 2-5, file has " +
                     std::to_string(lines.size()) + " line(s)");
  }
  const char* names[4] = {"principal distance", "x offset", "y offset", "pixel size"};
  double values[4];
  for (int i = 0; i < 4; ++i) {
    values[i] = detail::parseNumbers(lines[i + 1], 1,
                                     "JointTrack calibration '" + path + "' line " +
                                         std::to_string(i + 2) + " (" + names[i] + ")")[0];
  }
  JointTrackCalibration c;
  c.principal_distance_mm = values[0];
  c.x_offset_mm = values[1];
  c.y_offset_mm = values[2];
  c.pixel_size_mm = values[3];
  if (c.principal_distance_mm <= 0.0 || c.pixel_size_mm <= 0.0) {
    throw InputError("JointTrack calibration '" + path +
                     "': principal distance and pixel size must be positive");
  }
  if (full) {
    // Skip blank lines between the intrinsics and the three extrinsic vectors.
    std::vector<std::string> rest;
    for (std::size_t i = 5; i < lines.size(); ++i) {
      if (!lines[i].empty()) rest.push_back(lines[i]);
    }
    const std::string context = "JointTrack calibration '" + path + "' extrinsics";
    JointTrackExtrinsics e;
    e.source_position_mm = vectorLine(rest, 0, context + " (source position)");
    e.image_normal = vectorLine(rest, 1, context + " (image normal)");
    e.image_up = vectorLine(rest, 2, context + " (image up vector)");
    if (e.image_normal.norm() == 0.0 || e.image_up.norm() == 0.0 ||
        e.image_normal.normalized().cross(e.image_up.normalized()).norm() < 1e-6) {
      throw InputError(context + ": image normal and up vector must be non-zero and not parallel");
    }
    c.extrinsics = e;
  }
  return c;
}

void writeJointTrackCalibration(const std::string& path, const JointTrackCalibration& c) {
  std::ofstream out(path);
  if (!out) throw InputError("cannot write JointTrack calibration '" + path + "'");
  out << std::setprecision(10);
  out << (c.extrinsics ? kFullHeader : kIntrinsicHeader) << "\n"
      << c.principal_distance_mm << "\n"
      << c.x_offset_mm << "\n"
      << c.y_offset_mm << "\n"
      << c.pixel_size_mm << "\n";
  if (c.extrinsics) {
    const auto line = [&out](const Eigen::Vector3d& v) {
      out << v.x() << "," << v.y() << "," << v.z() << "\n";
    };
    out << "\n";
    line(c.extrinsics->source_position_mm);
    line(c.extrinsics->image_normal);
    line(c.extrinsics->image_up);
  }
  if (!out) throw InputError("failed while writing JointTrack calibration '" + path + "'");
}

geometry::XrayCamera cameraFromJointTrack(const JointTrackCalibration& c, int width, int height,
                                          const std::string& frame_id) {
  const double f = c.principal_distance_mm / c.pixel_size_mm;
  const double cx = 0.5 * width - c.x_offset_mm / c.pixel_size_mm;
  const double cy = 0.5 * height - 1.0 + c.y_offset_mm / c.pixel_size_mm;
  geometry::XrayCamera camera(width, height, f, f, cx, cy, frame_id);
  if (c.extrinsics) {
    // JointTrack camera axes in the lab: z toward the source (the image normal), y up.
    const Eigen::Vector3d z_jt = c.extrinsics->image_normal.normalized();
    const Eigen::Vector3d y_jt =
        (c.extrinsics->image_up - c.extrinsics->image_up.dot(z_jt) * z_jt).normalized();
    const Eigen::Vector3d x_jt = y_jt.cross(z_jt);
    Eigen::Matrix3d world_from_optical;
    world_from_optical << x_jt, -y_jt, -z_jt;
    camera.setWorldFromCamera(
        geometry::makePose(world_from_optical, 1e-3 * c.extrinsics->source_position_mm));
  }
  return camera;
}

}  // namespace io
}  // namespace fluoro_tracker
