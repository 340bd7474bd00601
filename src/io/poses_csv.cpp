#include "fluoro_tracker/io/poses_csv.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "fluoro_tracker/input_error.h"
#include "text_lines.h"

namespace fluoro_tracker {
namespace io {

const char kPosesCsvHeader[] = "frame,stamp,bone,x_m,y_m,z_m,qx,qy,qz,qw,status";

std::vector<PoseRecord> readPosesCsv(const std::string& path) {
  const auto lines = detail::readTrimmedLines(path, "poses CSV");
  detail::requireHeader(lines, kPosesCsvHeader, "poses CSV", path);
  std::vector<PoseRecord> records;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    if (lines[i].empty()) continue;
    const std::string context = "poses CSV '" + path + "' line " + std::to_string(i + 1);
    const auto f = detail::splitCsv(lines[i]);
    if (f.size() < 11) {
      throw InputError(context + ": expected 11 columns, found " + std::to_string(f.size()));
    }
    PoseRecord r;
    const auto number = [&](int column) {
      return detail::parseNumbers(f[column], 1,
                                  context + " column " + std::to_string(column + 1))[0];
    };
    r.frame = detail::parseFrameIndex(f[0], context);
    r.stamp = number(1);
    r.bone = f[2];
    if (r.bone.empty()) throw InputError(context + ": empty bone name");
    const Eigen::Vector3d t(number(3), number(4), number(5));
    Eigen::Quaterniond q(number(9), number(6), number(7), number(8));
    if (std::abs(q.norm() - 1.0) > 1e-3) {
      throw InputError(context + ": quaternion is not unit length (norm " +
                       std::to_string(q.norm()) + ")");
    }
    r.pose = geometry::makePose(q, t);
    r.status = f[10];
    if (!detail::isTrackingStatus(r.status)) {
      throw InputError(context + ": status '" + r.status + "' is not ok, suspect or lost");
    }
    records.push_back(std::move(r));
  }
  return records;
}

void writePosesCsv(const std::string& path, const std::vector<PoseRecord>& records) {
  std::ofstream out(path);
  if (!out) throw InputError("cannot write poses CSV '" + path + "'");
  const bool with_quality = std::any_of(records.begin(), records.end(),
                                        [](const PoseRecord& r) { return r.quality.has_value(); });
  out << kPosesCsvHeader
      << (with_quality
              ? ",contour_inlier_fraction,contour_rms_px,out_of_plane_sd_mm,contour_spread_px,"
                "offset_inlier_fraction,unseen_fraction"
              : "")
      << "\n";
  char buffer[512];
  for (const auto& r : records) {
    if (!geometry::isValidPose(r.pose)) {
      throw InputError("refusing to write a non-finite pose for bone '" + r.bone + "' frame " +
                       std::to_string(r.frame) + " to '" + path + "'");
    }
    const Eigen::Quaterniond q(r.pose.linear());
    const Eigen::Vector3d& t = r.pose.translation();
    std::snprintf(buffer, sizeof(buffer), "%d,%.9f,%s,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%s",
                  r.frame, r.stamp, r.bone.c_str(), t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w(),
                  r.status.c_str());
    out << buffer;
    if (with_quality) {
      const registration::BoneQuality q = r.quality.value_or(registration::BoneQuality());
      const double sd_mm = q.out_of_plane_sd_m >= 0.0 ? 1e3 * q.out_of_plane_sd_m : -1.0;
      std::snprintf(buffer, sizeof(buffer), ",%.4f,%.4f,%.4f,%.4f,%.4f,%.4f",
                    q.contour_inlier_fraction, q.contour_rms_px, sd_mm, q.contour_spread_px,
                    q.offset_inlier_fraction, registration::unseenFraction(q));
      out << buffer;
    }
    out << "\n";
  }
  if (!out) throw InputError("failed while writing poses CSV '" + path + "'");
}

}  // namespace io
}  // namespace fluoro_tracker
