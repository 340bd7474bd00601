#include "fluoro_tracker/geometry/xray_camera.h"

#include <cmath>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace geometry {

XrayCamera::XrayCamera(int width, int height, double fx, double fy, double cx, double cy,
                       std::string frame_id)
    : width_(width),
      height_(height),
      fx_(fx),
      fy_(fy),
      cx_(cx),
      cy_(cy),
      frame_id_(std::move(frame_id)) {
  if (width <= 0 || height <= 0) {
    throw InputError("camera image size must be positive, got " + std::to_string(width) + "x" +
                     std::to_string(height));
  }
  if (!std::isfinite(fx) || !std::isfinite(fy) || !std::isfinite(cx) || !std::isfinite(cy)) {
    throw InputError("camera intrinsics must be finite");
  }
  if (fx <= 0.0 || fy <= 0.0) {
    throw InputError("camera focal lengths fx, fy must be positive (got " + std::to_string(fx) +
                     ", " + std::to_string(fy) + ")");
  }
}

XrayCamera XrayCamera::fromCameraInfo(int width, int height, const std::array<double, 9>& k,
                                      const std::string& frame_id) {
  if (k[0] == 0.0) {
    throw InputError("camera_info for frame '" + frame_id + "' is uncalibrated: K[0] (fx) is 0");
  }
  for (double value : k) {
    if (!std::isfinite(value)) {
      throw InputError("camera_info for frame '" + frame_id + "' has a non-finite K entry");
    }
  }
  if (k[1] != 0.0) {
    throw InputError("camera_info for frame '" + frame_id +
                     "' has a skewed K (K[1] != 0), which an X-ray detector does not have");
  }
  if (frame_id.empty()) throw InputError("camera_info has an empty header.frame_id");
  return XrayCamera(width, height, k[0], k[4], k[2], k[5], frame_id);
}

std::array<double, 9> XrayCamera::cameraInfoK() const {
  return {fx_, 0.0, cx_, 0.0, fy_, cy_, 0.0, 0.0, 1.0};
}

void XrayCamera::setWorldFromCamera(const Pose& world_from_camera) {
  if (!isValidPose(world_from_camera)) {
    throw InputError("camera '" + frame_id_ + "' pose is not a finite rigid transform");
  }
  world_from_camera_ = world_from_camera;
}

bool XrayCamera::project(const Eigen::Vector3d& p, Eigen::Vector2d* pixel) const {
  if (!(p.z() > 0.0)) return false;
  *pixel = Eigen::Vector2d(fx_ * p.x() / p.z() + cx_, fy_ * p.y() / p.z() + cy_);
  return true;
}

Eigen::Vector3d XrayCamera::backProject(const Eigen::Vector2d& pixel) const {
  return pixelRay(pixel).normalized();
}

bool XrayCamera::contains(const Eigen::Vector2d& pixel) const {
  return pixel.x() >= -0.5 && pixel.y() >= -0.5 && pixel.x() < width_ - 0.5 &&
         pixel.y() < height_ - 0.5;
}

XrayCamera XrayCamera::scaled(double factor) const {
  // Pixel centres: u_scaled + 0.5 = factor * (u + 0.5).
  XrayCamera out(static_cast<int>(std::lround(width_ * factor)),
                 static_cast<int>(std::lround(height_ * factor)), fx_ * factor, fy_ * factor,
                 (cx_ + 0.5) * factor - 0.5, (cy_ + 0.5) * factor - 0.5, frame_id_);
  out.world_from_camera_ = world_from_camera_;
  return out;
}

XrayCamera XrayCamera::cropped(int x, int y, int width, int height) const {
  XrayCamera out(width, height, fx_, fy_, cx_ - x, cy_ - y, frame_id_);
  out.world_from_camera_ = world_from_camera_;
  return out;
}

}  // namespace geometry
}  // namespace fluoro_tracker
