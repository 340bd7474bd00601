#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/registration/frame_quality.h"

namespace fluoro_tracker {
namespace io {

// One row of the public poses CSV (docs: interfaces.md):
//   frame,stamp,bone,x_m,y_m,z_m,qx,qy,qz,qw,status
// frame counts images from 0, stamp is the image stamp in seconds, the pose is of the bone
// frame in the trial's fixed frame, status is ok, suspect or lost.
struct PoseRecord {
  int frame = 0;
  double stamp = 0.0;
  std::string bone;
  geometry::Pose pose = geometry::Pose::Identity();
  std::string status = "ok";
  // Written as extra columns after `status` when set: contour_inlier_fraction,
  // contour_rms_px, out_of_plane_sd_mm (-1 when not computed), contour_spread_px,
  // offset_inlier_fraction, unseen_fraction (newest last, so that readers of the earlier
  // columns by position still find them).
  std::optional<registration::BoneQuality> quality;
};

extern const char kPosesCsvHeader[];

// Reads a poses CSV; columns after `status` are ignored. Throws InputError naming the file and
// line for a wrong header, a malformed row, a non-finite value or an unknown status.
std::vector<PoseRecord> readPosesCsv(const std::string& path);
void writePosesCsv(const std::string& path, const std::vector<PoseRecord>& records);

}  // namespace io
}  // namespace fluoro_tracker
