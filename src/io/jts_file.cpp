#include "fluoro_tracker/io/jts_file.h"

#include <cstdio>
#include <fstream>

#include "fluoro_tracker/input_error.h"
#include "text_lines.h"

namespace fluoro_tracker {
namespace io {
namespace {

constexpr char kHeader[] = "JT_EULER_312";
constexpr char kMissing[] = "NOT_OPTIMIZED";

}  // namespace

JtsPoses readJtsFile(const std::string& path) {
  const auto lines = detail::readTrimmedLines(path, "JointTrack pose file");
  if (lines[0] != kHeader) {
    throw InputError("JointTrack pose file '" + path + "': first line is '" + lines[0] +
                     "', expected JT_EULER_312 (other conventions are not supported)");
  }
  if (lines.size() < 2 || lines[1].find("x_tran") == std::string::npos) {
    throw InputError("JointTrack pose file '" + path +
                     "': second line must be the column labels x_tran,y_tran,z_tran,...");
  }
  JtsPoses poses;
  for (std::size_t i = 2; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    if (line.empty()) continue;
    if (line.rfind(kMissing, 0) == 0) {
      poses.emplace_back(std::nullopt);
      continue;
    }
    const auto v = detail::parseNumbers(
        line, 6, "JointTrack pose file '" + path + "' line " + std::to_string(i + 1));
    geometry::EulerZXY angles;
    angles.z = geometry::degToRad(v[3]);
    angles.x = geometry::degToRad(v[4]);
    angles.y = geometry::degToRad(v[5]);
    poses.emplace_back(geometry::makePose(geometry::rotationFromEulerZXY(angles),
                                          Eigen::Vector3d(v[0], v[1], v[2])));
  }
  return poses;
}

void writeJtsFile(const std::string& path, const JtsPoses& poses) {
  std::ofstream out(path);
  if (!out) throw InputError("cannot write JointTrack pose file '" + path + "'");
  out << kHeader << "\n";
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), "%16s,%16s,%16s,%24s,%16s,%16s\n", "x_tran", "y_tran",
                "z_tran", "z_rot", "x_rot", "y_rot");
  out << buffer;
  for (const auto& pose : poses) {
    if (!pose) {
      out << kMissing << "\n";
      continue;
    }
    const auto a = geometry::eulerZXYFromRotation(pose->linear());
    const Eigen::Vector3d& t = pose->translation();
    std::snprintf(buffer, sizeof(buffer), "%16.9g,%16.9g,%16.9g,%24.9g,%16.9g,%16.9g\n", t.x(),
                  t.y(), t.z(), geometry::radToDeg(a.z), geometry::radToDeg(a.x),
                  geometry::radToDeg(a.y));
    out << buffer;
  }
  if (!out) throw InputError("failed while writing JointTrack pose file '" + path + "'");
}

geometry::Pose opticalFromJointTrack(const geometry::Pose& jointtrack_pose_mm) {
  geometry::Pose metres = jointtrack_pose_mm;
  metres.translation() *= 1e-3;
  return geometry::jointTrackToOptical() * metres;
}

geometry::Pose jointTrackFromOptical(const geometry::Pose& optical_pose_m) {
  geometry::Pose jt = geometry::jointTrackToOptical() * optical_pose_m;  // self-inverse
  jt.translation() *= 1e3;
  return jt;
}

}  // namespace io
}  // namespace fluoro_tracker
