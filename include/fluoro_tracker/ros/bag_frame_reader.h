#pragma once

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/xray_camera.h"

namespace fluoro_tracker {
namespace ros_bridge {

// One fluoroscopy frame from a bag: an image per view, all with the same header stamp, with
// each view's camera placed in the fixed frame (worldFromCamera()).
struct BagFrame {
  int index = 0;  // counts frames (used and skipped) from 0 in bag order
  double stamp_s = 0.0;
  std::vector<cv::Mat> images;
  std::vector<geometry::XrayCamera> cameras;
};

// Reads the images of one or more views from a bag in one pass, in bag order. An image topic
// carries sensor_msgs/Image or sensor_msgs/CompressedImage (image_transport's compressed
// transport, e.g. ".../image_raw/compressed": PNG or JPEG, decoded with OpenCV). Each image
// topic's camera_info is its sibling ".../camera_info" (of ".../image_raw" for a compressed
// ".../image_raw/compressed"; the latest one received before the image). With several views,
// /tf_static in the bag places each optical frame in the fixed frame, and images of the views
// are grouped by identical header stamps.
class BagFrameReader {
 public:
  using FrameCallback = std::function<void(const BagFrame&)>;
  using SkipCallback = std::function<void(int index, double stamp_s, const std::string& reason)>;

  // `image_topics` empty: every sensor_msgs/Image topic in the bag, and every
  // sensor_msgs/CompressedImage topic whose raw stream is not in it. `fixed_frame` empty: the
  // first view's optical frame. Throws InputError for a missing or unreadable bag, no image
  // topics, or an image topic whose camera_info topic is absent from the bag.
  BagFrameReader(const std::string& bag_path, std::vector<std::string> image_topics,
                 std::string fixed_frame);
  ~BagFrameReader();

  const std::vector<std::string>& imageTopics() const { return image_topics_; }
  // The fixed frame: as given, or the first view's optical frame once read() has seen it.
  const std::string& fixedFrame() const { return fixed_frame_; }
  // Messages on the first image topic: the frame count of a complete bag.
  std::size_t expectedFrames() const { return expected_frames_; }

  // Calls `consume` for each complete frame and `skipped` for each frame that cannot be used
  // (wrong encoding, compressed data that does not decode, no camera_info yet, a view not tied to
  // the fixed frame, a view missing at that stamp), with the reason.
  void read(const FrameCallback& consume, const SkipCallback& skipped);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<std::string> image_topics_;
  std::string fixed_frame_;
  std::size_t expected_frames_ = 0;
};

}  // namespace ros_bridge
}  // namespace fluoro_tracker
