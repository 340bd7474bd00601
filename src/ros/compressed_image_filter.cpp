#include "fluoro_tracker/ros/compressed_image_filter.h"

#include <boost/make_shared.hpp>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/ros/conversions.h"

namespace fluoro_tracker {
namespace ros_bridge {

CompressedImageFilter::CompressedImageFilter(ros::NodeHandle& nh, const std::string& base_topic,
                                             std::uint32_t queue_size) {
  subscriber_ = nh.subscribe(base_topic + "/compressed", queue_size,
                             &CompressedImageFilter::onCompressed, this);
}

void CompressedImageFilter::onCompressed(const sensor_msgs::CompressedImageConstPtr& message) {
  sensor_msgs::ImageConstPtr image;
  try {
    image = boost::make_shared<sensor_msgs::Image>(
        toImageMessage(fromCompressedImageMessage(*message), message->header));
  } catch (const InputError& e) {
    ++skipped_;
    ROS_ERROR_THROTTLE(5.0, "tracker_node: compressed frame at %.3f on %s skipped: %s",
                       message->header.stamp.toSec(), subscriber_.getTopic().c_str(), e.what());
    return;
  }
  signalMessage(image);
}

}  // namespace ros_bridge
}  // namespace fluoro_tracker
