#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fluoro_tracker/geometry/pose.h"

namespace fluoro_tracker {
namespace io {

// JointTrack pose files (.jts, JT_EULER_312): a header line, a column-label line, then one row
// per frame "x_tran,y_tran,z_tran,z_rot,x_rot,y_rot" in millimetres and degrees, with
// R = Rz·Rx·Ry, so a model point v maps to R·v + t in JointTrack's camera frame. A row starting
// with NOT_OPTIMIZED is a frame without a pose (std::nullopt).
//
// The poses returned and accepted here are exactly the file's: JointTrack camera frame,
// millimetres. Use opticalFromJointTrack()/jointTrackFromOptical() to move to the ROS optical
// frame in metres.
using JtsPoses = std::vector<std::optional<geometry::Pose>>;

JtsPoses readJtsFile(const std::string& path);
void writeJtsFile(const std::string& path, const JtsPoses& poses);

// T_optical_bone (metres) from a JointTrack pose T_jt_bone (millimetres), and back.
geometry::Pose opticalFromJointTrack(const geometry::Pose& jointtrack_pose_mm);
geometry::Pose jointTrackFromOptical(const geometry::Pose& optical_pose_m);

}  // namespace io
}  // namespace fluoro_tracker
