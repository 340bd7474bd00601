#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <rosbag/bag.h>
#include <opencv2/core.hpp>

#include "fluoro_tracker/io/fluoro_view.h"
#include "fluoro_tracker/ros/conversions.h"
#include "fluoro_tracker/sim/trial_simulator.h"

namespace fluoro_tracker {
namespace ros_bridge {

// Writes a trial's frames (simulated, or real images with their calibrations) as a bag per the
// public contract: for one view /fluoro/image_raw and /fluoro/camera_info (frame
// fluoro_optical); for N views /fluoroK/image_raw and /fluoroK/camera_info (frames
// fluoroK_optical) plus latched /tf_static tying each optical frame to the fixed frame.
// Message and bag times are the image stamps. Optionally the images are stored as
// image_transport's compressed transport does (sensor_msgs/CompressedImage on
// .../image_raw/compressed): PNG keeps every grey value in a third to a half of the space.
class TrialBagWriter {
 public:
  struct Compression {
    ImageCompression format = ImageCompression::kPng;
    int jpeg_quality = 95;
  };
  // A tool's --compression none|png|jpeg and --jpeg-quality (1-100): unset for none. Throws
  // InputError naming the option for another text or a quality out of range.
  static std::optional<Compression> compressionFromOptions(const std::string& text,
                                                           int jpeg_quality);

  // Opens (truncates) the bag and, for several views, writes /tf_static. `compression` unset:
  // raw sensor_msgs/Image. Throws InputError if the file cannot be created.
  TrialBagWriter(const std::string& path, const std::vector<io::FluoroView>& views,
                 const std::string& fixed_frame, double first_stamp_s,
                 std::optional<Compression> compression = std::nullopt);
  ~TrialBagWriter();

  // The topic this writer puts a view's images on.
  std::string imageTopic(const io::FluoroView& view) const {
    return "/" + view.name + "/image_raw" + (compression_ ? "/compressed" : "");
  }
  static std::string cameraInfoTopic(const io::FluoroView& view) {
    return "/" + view.name + "/camera_info";
  }

  // One frame: an image per view (mono8 or mono16), all stamped `stamp_s`. Throws InputError
  // (naming frame `index`) for a wrong number of images or an image of another type.
  void write(int index, double stamp_s, const std::vector<cv::Mat>& images);
  void write(const sim::SimulatedFrame& frame) { write(frame.index, frame.stamp_s, frame.images); }
  void close();

 private:
  rosbag::Bag bag_;
  std::vector<io::FluoroView> views_;
  std::optional<Compression> compression_;
  std::uint32_t sequence_ = 0;
};

}  // namespace ros_bridge
}  // namespace fluoro_tracker
