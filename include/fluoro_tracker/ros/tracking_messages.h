#pragma once

#include <string>
#include <vector>

#include <geometry_msgs/TransformStamped.h>
#include <std_msgs/Header.h>

#include "fluoro_tracker/JointKinematics.h"
#include "fluoro_tracker/TrackingStatus.h"
#include "fluoro_tracker/registration/tracker.h"

namespace fluoro_tracker {
namespace ros_bridge {

// The ROS messages of one tracked frame, shared by tracker_node (published) and track_bag
// --out-bag (recorded), so that a live run and an offline one produce the same messages.

// tf fixed_frame -> <bone> for every bone, stamped with the image stamp.
std::vector<geometry_msgs::TransformStamped> boneTransforms(
    const ros::Time& stamp, const std::string& fixed_frame,
    const registration::Registrar& registrar, const registration::TrackedFrame& tracked);

// A joint's coordinates at a tracked frame, in its type's convention (kinematics::JointType):
// from the registration when it ran, else computed from the poses reported.
kinematics::KneeCoordinates jointCoordinates(const registration::Registrar& registrar,
                                             std::size_t joint,
                                             const registration::TrackedFrame& tracked);
// "lost" when either of the joint's bones is, "ok" when both are, else "suspect".
std::string jointStatus(const registration::Registrar& registrar, std::size_t joint,
                        const registration::TrackedFrame& tracked);

// False (and no message) when a coordinate is not finite.
bool kinematicsMessage(const ros::Time& stamp, const registration::Registrar& registrar,
                       std::size_t joint, const registration::TrackedFrame& tracked,
                       double compressive_force_n, bool loaded, JointKinematics* message);

// A joint's coordinates as text for an rviz label: name and status, then the angles in degrees
// and the translations in millimetres, named as in the message.
std::string kinematicsLabel(const JointKinematics& kinematics);

TrackingStatus statusMessage(const std_msgs::Header& header,
                             const registration::Registrar& registrar,
                             const registration::TrackedFrame& tracked,
                             std::uint32_t frames_dropped);

}  // namespace ros_bridge
}  // namespace fluoro_tracker
