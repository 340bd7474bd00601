#pragma once

// Conversions between the ROS-free core types and ROS messages. The only layer (with tools/)
// that includes ROS headers.

#include <string>

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
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

// How image_transport's "compressed" transport stores a frame: PNG (lossless, 8 or 16 bit) or
// JPEG (lossy, 8 bit only).
enum class ImageCompression { kPng, kJpeg };
// "png" or "jpeg"; throws InputError naming `option` and the choices otherwise.
ImageCompression parseImageCompression(const std::string& text, const std::string& option);
// A grey image (CV_8U or CV_16U) as image_transport's compressed transport writes it, format
// "<encoding>; <png|jpeg> compressed <encoding>". Throws InputError for another image type or a
// 16-bit image as JPEG.
sensor_msgs::CompressedImage toCompressedImageMessage(const cv::Mat& image,
                                                      const std_msgs::Header& header,
                                                      ImageCompression compression,
                                                      int jpeg_quality = 95);
// Grey image (CV_8U or CV_16U) decoded from a CompressedImage (PNG, JPEG or any format OpenCV
// reads; colour converted to grey). Throws InputError naming the frame and the format for a
// depth image (compressedDepth) or data that does not decode.
cv::Mat fromCompressedImageMessage(const sensor_msgs::CompressedImage& message);

geometry_msgs::Transform toTransformMessage(const geometry::Pose& pose);
geometry_msgs::Pose toPoseMessage(const geometry::Pose& pose);
// Throws InputError for a non-finite pose or a quaternion far from unit length.
geometry::Pose fromPoseMessage(const geometry_msgs::Pose& message);

}  // namespace ros_bridge
}  // namespace fluoro_tracker
