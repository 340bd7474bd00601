#include "fluoro_tracker/io/kinematics_csv.h"

#include <cmath>
#include <cstdio>
#include <fstream>

#include "fluoro_tracker/input_error.h"
#include "text_lines.h"

namespace fluoro_tracker {
namespace io {

const char kKinematicsCsvHeader[] =
    "frame,stamp,joint,flexion_deg,adduction_deg,internal_rotation_deg,x_mm,y_mm,z_mm,status";

namespace {
constexpr double kDegPerRad = 180.0 / M_PI;
}  // namespace

void writeKinematicsCsv(const std::string& path, const std::vector<KinematicsRecord>& records) {
  std::ofstream out(path);
  if (!out) throw InputError("cannot write kinematics CSV '" + path + "'");
  out << kKinematicsCsvHeader << "\n";
  char buffer[512];
  for (const auto& r : records) {
    const auto& c = r.coordinates;
    const double values[6] = {c.flexion_rad, c.adduction_rad, c.internal_rotation_rad,
                              c.x_m,         c.y_m,           c.z_m};
    for (double v : values) {
      if (!std::isfinite(v)) {
        throw InputError("refusing to write non-finite kinematics for joint '" + r.joint +
                         "' frame " + std::to_string(r.frame) + " to '" + path + "'");
      }
    }
    std::snprintf(buffer, sizeof(buffer), "%d,%.9f,%s,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%s\n", r.frame,
                  r.stamp, r.joint.c_str(), kDegPerRad * c.flexion_rad,
                  kDegPerRad * c.adduction_rad, kDegPerRad * c.internal_rotation_rad, 1e3 * c.x_m,
                  1e3 * c.y_m, 1e3 * c.z_m, r.status.c_str());
    out << buffer;
  }
  if (!out) throw InputError("failed while writing kinematics CSV '" + path + "'");
}

std::vector<KinematicsRecord> readKinematicsCsv(const std::string& path) {
  const auto lines = detail::readTrimmedLines(path, "kinematics CSV");
  detail::requireHeader(lines, kKinematicsCsvHeader, "kinematics CSV", path);
  std::vector<KinematicsRecord> records;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    if (lines[i].empty()) continue;
    const std::string context = "kinematics CSV '" + path + "' line " + std::to_string(i + 1);
    const auto f = detail::splitCsv(lines[i]);
    if (f.size() < 10) {
      throw InputError(context + ": expected 10 columns, found " + std::to_string(f.size()));
    }
    const auto number = [&](int column) {
      return detail::parseNumbers(f[column], 1,
                                  context + " column " + std::to_string(column + 1))[0];
    };
    KinematicsRecord r;
    r.frame = detail::parseFrameIndex(f[0], context);
    r.stamp = number(1);
    r.joint = f[2];
    r.coordinates = {number(3) / kDegPerRad, number(4) / kDegPerRad, number(5) / kDegPerRad,
                     number(6) * 1e-3,       number(7) * 1e-3,       number(8) * 1e-3};
    r.status = f[9];
    if (!detail::isTrackingStatus(r.status)) {
      throw InputError(context + ": status '" + r.status + "' is not ok, suspect or lost");
    }
    records.push_back(std::move(r));
  }
  return records;
}

}  // namespace io
}  // namespace fluoro_tracker
