#pragma once

// Conversions between the ROS-free core types and ROS messages. The only layer (with tools/)
// that includes ROS headers.

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/Header.h>

#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/imaging/lens_distortion.h"

namespace fluoro_tracker {
namespace ros_bridge {

// CameraInfo for a view: K from the camera, P = [K | 0], identity R, the lens distortion its
// frames carry (plumb_bob with zeros when none), header frame_id = the camera's optical frame.
sensor_msgs::CameraInfo toCameraInfo(const geometry::XrayCamera& camera, const ros::Time& stamp,
                                     const imaging::LensDistortion& distortion = {});
// The distortion model and coefficients of a CameraInfo (not validated).
imaging::LensDistortion lensDistortion(const sensor_msgs::CameraInfo& info);
// Throws InputError naming the frame for K[0] == 0, a zero size or a non-finite K.
geometry::XrayCamera fromCameraInfo(const sensor_msgs::CameraInfo& info);

// mono8 for CV_8U, mono16 for CV_16U; anything else throws InputError.
sensor_msgs::Image toImageMessage(const cv::Mat& image, const std_msgs::Header& header);
// Grey image (CV_8U or CV_16U) from a mono8/mono16 message (also accepts 8-bit colour, which is
// converted to grey). Throws InputError naming the encoding otherwise.
cv::Mat fromImageMessage(const sensor_msgs::Image& message);

geometry_msgs::Transform toTransformMessage(const geometry::Pose& pose);
geometry_msgs::Pose toPoseMessage(const geometry::Pose& pose);
// Throws InputError for a non-finite pose or a quaternion far from unit length.
geometry::Pose fromPoseMessage(const geometry_msgs::Pose& message);

}  // namespace ros_bridge
}  // namespace fluoro_tracker
