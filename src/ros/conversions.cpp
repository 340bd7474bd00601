#include "fluoro_tracker/ros/conversions.h"

#include <cmath>
#include <string>
#include <vector>

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace ros_bridge {

namespace enc = sensor_msgs::image_encodings;

sensor_msgs::CameraInfo toCameraInfo(const geometry::XrayCamera& camera, const ros::Time& stamp,
                                     const imaging::LensDistortion& distortion) {
  sensor_msgs::CameraInfo info;
  info.header.stamp = stamp;
  info.header.frame_id = camera.frameId();
  info.width = static_cast<std::uint32_t>(camera.width());
  info.height = static_cast<std::uint32_t>(camera.height());
  info.distortion_model = "plumb_bob";
  info.D = {0.0, 0.0, 0.0, 0.0, 0.0};
  if (distortion.distorts()) {
    info.distortion_model = distortion.model;
    info.D = distortion.coefficients;
  }
  const auto k = camera.cameraInfoK();
  std::copy(k.begin(), k.end(), info.K.begin());
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  info.P = {k[0], 0.0, k[2], 0.0, 0.0, k[4], k[5], 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

imaging::LensDistortion lensDistortion(const sensor_msgs::CameraInfo& info) {
  return {info.distortion_model, info.D};
}

geometry::XrayCamera fromCameraInfo(const sensor_msgs::CameraInfo& info) {
  std::array<double, 9> k;
  std::copy(info.K.begin(), info.K.end(), k.begin());
  return geometry::XrayCamera::fromCameraInfo(
      static_cast<int>(info.width), static_cast<int>(info.height), k, info.header.frame_id);
}

namespace {

// mono8 or mono16 for a grey image; throws InputError for any other type.
std::string greyEncoding(const cv::Mat& image) {
  if (image.type() == CV_8UC1) return enc::MONO8;
  if (image.type() == CV_16UC1) return enc::MONO16;
  throw InputError("only 8- or 16-bit single-channel images can be published (got OpenCV type " +
                   std::to_string(image.type()) + ")");
}

}  // namespace

sensor_msgs::Image toImageMessage(const cv::Mat& image, const std_msgs::Header& header) {
  sensor_msgs::Image message;
  cv_bridge::CvImage(header, greyEncoding(image), image).toImageMsg(message);
  return message;
}

cv::Mat fromImageMessage(const sensor_msgs::Image& message) {
  const std::string& e = message.encoding;
  try {
    if (e == enc::MONO8 || e == enc::MONO16 || e == enc::TYPE_8UC1 || e == enc::TYPE_16UC1) {
      return cv_bridge::toCvCopy(message)->image;
    }
    if (e == enc::BGR8 || e == enc::RGB8 || e == enc::BGRA8 || e == enc::RGBA8) {
      return cv_bridge::toCvCopy(message, enc::MONO8)->image;
    }
  } catch (const cv_bridge::Exception& ex) {
    throw InputError("image in frame '" + message.header.frame_id +
                     "' could not be converted: " + ex.what());
  }
  throw InputError("image in frame '" + message.header.frame_id + "' has encoding '" + e +
                   "'; expected mono8 or mono16 (or 8-bit colour)");
}

ImageCompression parseImageCompression(const std::string& text, const std::string& option) {
  if (text == "png") return ImageCompression::kPng;
  if (text == "jpeg") return ImageCompression::kJpeg;
  throw InputError(option + " '" + text + "' is not an image compression: png or jpeg");
}

sensor_msgs::CompressedImage toCompressedImageMessage(const cv::Mat& image,
                                                      const std_msgs::Header& header,
                                                      ImageCompression compression,
                                                      int jpeg_quality) {
  const std::string encoding = greyEncoding(image);
  const bool png = compression == ImageCompression::kPng;
  if (!png && image.depth() != CV_8U) {
    throw InputError("JPEG holds 8-bit images only; compress this " + encoding + " image as PNG");
  }
  sensor_msgs::CompressedImage message;
  message.header = header;
  message.format = encoding + (png ? "; png" : "; jpeg") + " compressed " + encoding;
  const std::vector<int> parameters =
      png ? std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, 3}
          : std::vector<int>{cv::IMWRITE_JPEG_QUALITY, jpeg_quality};
  if (!cv::imencode(png ? ".png" : ".jpg", image, message.data, parameters)) {
    throw InputError("OpenCV could not encode a " + encoding + " image as " +
                     (png ? "PNG" : "JPEG"));
  }
  return message;
}

cv::Mat fromCompressedImageMessage(const sensor_msgs::CompressedImage& message) {
  const std::string where = "compressed image in frame '" + message.header.frame_id +
                            "' (format '" + message.format + "')";
  if (message.format.find("compressedDepth") != std::string::npos) {
    throw InputError(where +
                     " is a depth image (compressedDepth); expected a grey fluoroscopy "
                     "frame");
  }
  if (message.data.empty()) throw InputError(where + " has no data");
  cv::Mat decoded;
  try {
    decoded = cv::imdecode(message.data, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw InputError(where + " could not be decoded: " + e.what());
  }
  if (decoded.empty()) throw InputError(where + " could not be decoded");
  if (decoded.depth() != CV_8U && decoded.depth() != CV_16U) {
    throw InputError(where + " decodes to OpenCV depth " + std::to_string(decoded.depth()) +
                     "; expected 8- or 16-bit grey");
  }
  if (decoded.channels() == 3) {
    cv::cvtColor(decoded, decoded, cv::COLOR_BGR2GRAY);
  } else if (decoded.channels() == 4) {
    cv::cvtColor(decoded, decoded, cv::COLOR_BGRA2GRAY);
  } else if (decoded.channels() != 1) {
    throw InputError(where + " decodes to " + std::to_string(decoded.channels()) +
                     " channels; expected grey or colour");
  }
  return decoded;
}

geometry_msgs::Transform toTransformMessage(const geometry::Pose& pose) {
  return tf2::eigenToTransform(pose).transform;
}

geometry_msgs::Pose toPoseMessage(const geometry::Pose& pose) {
  return tf2::toMsg(pose);
}

geometry::Pose fromPoseMessage(const geometry_msgs::Pose& m) {
  const Eigen::Quaterniond q(m.orientation.w, m.orientation.x, m.orientation.y, m.orientation.z);
  const Eigen::Vector3d t(m.position.x, m.position.y, m.position.z);
  if (!t.allFinite() || !q.coeffs().allFinite()) throw InputError("pose has a non-finite value");
  if (std::abs(q.norm() - 1.0) > 1e-3) {
    throw InputError("pose orientation is not a unit quaternion (norm " + std::to_string(q.norm()) +
                     ")");
  }
  return geometry::makePose(q, t);  // renormalises the quaternion
}

}  // namespace ros_bridge
}  // namespace fluoro_tracker
