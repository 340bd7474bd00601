#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>

#include <message_filters/simple_filter.h>
#include <ros/ros.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

namespace fluoro_tracker {
namespace ros_bridge {

// image_transport's "compressed" transport without its plugin, which Debian does not package
// (compressed_image_transport): subscribes to `<base_topic>/compressed` and passes each frame
// on decoded (fromCompressedImageMessage: PNG or JPEG, grey) as a sensor_msgs::Image with the
// same header, so that message_filters synchronise it with its camera_info as they would the
// raw stream. A frame that does not decode is logged with its reason and counted (skipped()).
class CompressedImageFilter : public message_filters::SimpleFilter<sensor_msgs::Image> {
 public:
  CompressedImageFilter(ros::NodeHandle& nh, const std::string& base_topic,
                        std::uint32_t queue_size);

  std::string getTopic() const { return subscriber_.getTopic(); }
  std::size_t skipped() const { return skipped_; }
  void shutdown() { subscriber_.shutdown(); }

 private:
  void onCompressed(const sensor_msgs::CompressedImageConstPtr& message);

  ros::Subscriber subscriber_;
  std::atomic<std::size_t> skipped_{0};
};

}  // namespace ros_bridge
}  // namespace fluoro_tracker
