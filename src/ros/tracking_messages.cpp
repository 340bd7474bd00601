#include "fluoro_tracker/ros/tracking_messages.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/ros/conversions.h"

namespace fluoro_tracker {
namespace ros_bridge {

std::vector<geometry_msgs::TransformStamped> boneTransforms(
    const ros::Time& stamp, const std::string& fixed_frame,
    const registration::Registrar& registrar, const registration::TrackedFrame& tracked) {
  std::vector<geometry_msgs::TransformStamped> transforms;
  for (std::size_t b = 0; b < registrar.bones().size(); ++b) {
    geometry_msgs::TransformStamped t;
    t.header.stamp = stamp;  // never now(): tf lines up with the image
    t.header.frame_id = fixed_frame;
    t.child_frame_id = registrar.bones()[b].name;
    t.transform = toTransformMessage(tracked.poses[b]);
    transforms.push_back(t);
  }
  return transforms;
}

kinematics::KneeCoordinates jointCoordinates(const registration::Registrar& registrar,
                                             std::size_t joint,
                                             const registration::TrackedFrame& tracked) {
  const auto& model = registrar.joints()[joint];
  // A frame whose solve failed has no joint results: its kinematics come from the poses it
  // reports.
  const std::vector<geometry::Pose>& poses =
      joint < tracked.result.joints.size() ? tracked.result.poses : tracked.poses;
  return model.reportedCoordinates(poses[model.parent], poses[model.child]);
}

std::string jointStatus(const registration::Registrar& registrar, std::size_t joint,
                        const registration::TrackedFrame& tracked) {
  const auto& model = registrar.joints()[joint];
  return registration::combinedStatus(tracked.status[model.parent], tracked.status[model.child]);
}

bool kinematicsMessage(const ros::Time& stamp, const registration::Registrar& registrar,
                       std::size_t joint, const registration::TrackedFrame& tracked,
                       double compressive_force_n, bool loaded, JointKinematics* message) {
  const auto& model = registrar.joints()[joint];
  const kinematics::KneeCoordinates c = jointCoordinates(registrar, joint, tracked);
  for (double v : {c.flexion_rad, c.adduction_rad, c.internal_rotation_rad, c.x_m, c.y_m, c.z_m}) {
    if (!std::isfinite(v)) return false;
  }
  const auto& bones = registrar.bones();
  message->header.stamp = stamp;
  message->header.frame_id = bones[model.parent].name;
  message->joint = model.name;
  message->parent = bones[model.parent].name;
  message->child = bones[model.child].name;
  const kinematics::JointCoordinateNames& names = kinematics::coordinateNames(model.type);
  std::copy(names.angles.begin(), names.angles.end(), message->angle_names.begin());
  message->angles = {c.flexion_rad, c.adduction_rad, c.internal_rotation_rad};
  std::copy(names.translations.begin(), names.translations.end(),
            message->translation_names.begin());
  message->translations = {c.x_m, c.y_m, c.z_m};
  message->status = jointStatus(registrar, joint, tracked);
  message->compressive_force_n = compressive_force_n;
  message->loaded = loaded && model.loaded_contact != nullptr;
  return true;
}

std::string kinematicsLabel(const JointKinematics& kinematics) {
  std::ostringstream label;
  label << std::fixed << std::setprecision(1) << kinematics.joint << " (" << kinematics.status
        << ")";
  for (std::size_t i = 0; i < kinematics.angles.size() && i < kinematics.angle_names.size(); ++i) {
    label << (i == 0 ? "\n" : "  ") << kinematics.angle_names[i] << " "
          << geometry::radToDeg(kinematics.angles[i]) << " deg";
  }
  for (std::size_t i = 0;
       i < kinematics.translations.size() && i < kinematics.translation_names.size(); ++i) {
    label << (i == 0 ? "\n" : "  ") << kinematics.translation_names[i] << " "
          << 1e3 * kinematics.translations[i] << " mm";
  }
  return label.str();
}

TrackingStatus statusMessage(const std_msgs::Header& header,
                             const registration::Registrar& registrar,
                             const registration::TrackedFrame& tracked,
                             std::uint32_t frames_dropped) {
  TrackingStatus status;
  status.header = header;
  for (std::size_t b = 0; b < registrar.bones().size(); ++b) {
    BoneStatus bone;
    bone.bone = registrar.bones()[b].name;
    bone.status = tracked.status[b];
    bone.cost = tracked.result.final_cost;
    bone.iterations = static_cast<std::uint32_t>(tracked.result.solver_iterations);
    bone.solve_time_s = tracked.solve_seconds;
    if (b < tracked.result.quality.size()) {
      const registration::BoneQuality& q = tracked.result.quality[b];
      bone.contour_inlier_fraction = q.contour_inlier_fraction;
      bone.contour_rms_px = q.contour_rms_px;
      bone.out_of_plane_sd_m = q.out_of_plane_sd_m;
      bone.contour_spread_px = q.contour_spread_px;
      bone.offset_inlier_fraction = q.offset_inlier_fraction;
      bone.unseen_fraction = registration::unseenFraction(q);
    } else {
      bone.out_of_plane_sd_m = -1.0;
    }
    bone.searched = tracked.searched;
    status.bones.push_back(bone);
  }
  status.frames_dropped = frames_dropped;
  status.given_up = tracked.given_up;
  return status;
}

}  // namespace ros_bridge
}  // namespace fluoro_tracker
