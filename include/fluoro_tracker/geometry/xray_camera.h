#pragma once

#include <array>
#include <string>

#include <Eigen/Core>

#include "fluoro_tracker/geometry/pose.h"

namespace fluoro_tracker {
namespace geometry {

// A fluoroscope view as a pinhole camera whose optical centre is the X-ray source, in the ROS
// optical convention: z from the source toward the detector, x to the right and y down in the
// image. Pixel (u, v) = (0, 0) is the centre of the top-left pixel (OpenCV / CameraInfo).
// Lengths in metres; fx = fy = principal distance / pixel spacing for a square-pixel detector.
//
// JointTrack describes the same fluoroscope in a frame with x right, y up and z toward the
// source (objects at negative z); jointTrackToOptical() in pose.h converts poses between the two.
class XrayCamera {
 public:
  XrayCamera() = default;
  // Throws InputError for a non-positive size or focal length or non-finite values.
  XrayCamera(int width, int height, double fx, double fy, double cx, double cy,
             std::string frame_id = "fluoro_optical");

  // From sensor_msgs/CameraInfo fields (row-major K). Rejects K[0] == 0 (an uncalibrated camera
  // by the CameraInfo convention), zero image sizes and non-finite entries.
  static XrayCamera fromCameraInfo(int width, int height, const std::array<double, 9>& k,
                                   const std::string& frame_id);
  // K in CameraInfo's row-major layout.
  std::array<double, 9> cameraInfoK() const;

  int width() const { return width_; }
  int height() const { return height_; }
  double fx() const { return fx_; }
  double fy() const { return fy_; }
  double cx() const { return cx_; }
  double cy() const { return cy_; }
  const std::string& frameId() const { return frame_id_; }
  void setFrameId(const std::string& frame_id) { frame_id_ = frame_id; }

  // Pose of this view's optical frame in the lab (world) frame; identity for a lone view.
  const Pose& worldFromCamera() const { return world_from_camera_; }
  void setWorldFromCamera(const Pose& world_from_camera);

  // Projects a point given in the optical frame. Returns false (and leaves pixel alone) for a
  // point at or behind the source plane, which has no image.
  bool project(const Eigen::Vector3d& point_camera, Eigen::Vector2d* pixel) const;
  // Unit direction, in the optical frame, of the ray from the source through a pixel.
  Eigen::Vector3d backProject(const Eigen::Vector2d& pixel) const;
  // The same ray scaled so that its z component is 1.
  Eigen::Vector3d pixelRay(const Eigen::Vector2d& pixel) const {
    return {(pixel.x() - cx_) / fx_, (pixel.y() - cy_) / fy_, 1.0};
  }
  bool contains(const Eigen::Vector2d& pixel) const;

  // The same camera with its image scaled by `factor` (e.g. 0.5 for a half-resolution pyramid
  // level); pixel centres stay consistent with cv::resize.
  XrayCamera scaled(double factor) const;
  // The same camera restricted to the pixel rectangle starting at (x, y): pixel (u, v) of the
  // crop is pixel (u + x, v + y) of this camera.
  XrayCamera cropped(int x, int y, int width, int height) const;

 private:
  int width_ = 0;
  int height_ = 0;
  double fx_ = 0.0;
  double fy_ = 0.0;
  double cx_ = 0.0;
  double cy_ = 0.0;
  std::string frame_id_ = "fluoro_optical";
  Pose world_from_camera_ = Pose::Identity();
};

}  // namespace geometry
}  // namespace fluoro_tracker
