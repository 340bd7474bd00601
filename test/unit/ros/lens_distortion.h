#pragma once

#include <sensor_msgs/CameraInfo.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace fluoro_tracker {
namespace test_support {

// A pinhole frame as a lens with `info`'s plumb_bob distortion would show it: each pixel of
// the distorted frame samples the pinhole frame where the undistorted ray falls (OpenCV's
// point undistortion, the inverse of the maps under test).
inline cv::Mat withLensDistortion(const cv::Mat& pinhole, const sensor_msgs::CameraInfo& info) {
  const cv::Matx33d k(info.K[0], info.K[1], info.K[2], info.K[3], info.K[4], info.K[5], info.K[6],
                      info.K[7], info.K[8]);
  std::vector<cv::Point2f> distorted;
  for (int v = 0; v < pinhole.rows; ++v) {
    for (int u = 0; u < pinhole.cols; ++u) distorted.emplace_back(u, v);
  }
  std::vector<cv::Point2f> undistorted;
  cv::undistortPoints(distorted, undistorted, k, cv::Mat(info.D, true), cv::noArray(), k);
  cv::Mat map_x(pinhole.size(), CV_32FC1);
  cv::Mat map_y(pinhole.size(), CV_32FC1);
  for (int v = 0; v < pinhole.rows; ++v) {
    for (int u = 0; u < pinhole.cols; ++u) {
      const cv::Point2f& p = undistorted[static_cast<std::size_t>(v) * pinhole.cols + u];
      map_x.at<float>(v, u) = p.x;
      map_y.at<float>(v, u) = p.y;
    }
  }
  cv::Mat out;
  cv::remap(pinhole, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

}  // namespace test_support
}  // namespace fluoro_tracker
