#include "fluoro_tracker/ros/result_bag.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2_msgs/TFMessage.h>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/ros/tracking_messages.h"

namespace fluoro_tracker {
namespace ros_bridge {

ResultBag::ResultBag(const std::string& path) : path_(path), bag_(std::make_unique<rosbag::Bag>()) {
  try {
    bag_->open(path, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    throw InputError("cannot write output bag '" + path + "': " + e.what());
  }
}

ResultBag::~ResultBag() {
  try {
    close();
  } catch (...) {
    // Destructors must not throw; close() reports errors when called explicitly.
  }
}

void ResultBag::addFrame(double stamp_s, const std::string& fixed_frame,
                         const registration::Registrar& registrar,
                         const registration::TrackedFrame& tracked) {
  const ros::Time stamp(stamp_s);
  tf2_msgs::TFMessage tf;
  tf.transforms = boneTransforms(stamp, fixed_frame, registrar, tracked);
  bag_->write("/tf", stamp, tf);
  for (std::size_t j = 0; j < registrar.joints().size(); ++j) {
    JointKinematics message;
    if (kinematicsMessage(stamp, registrar, j, tracked, 0.0, false, &message)) {
      bag_->write("/fluoro_tracker/kinematics", stamp, message);
    }
  }
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = fixed_frame;
  bag_->write("/fluoro_tracker/status", stamp, statusMessage(header, registrar, tracked, 0));
}

void ResultBag::copyInput(const std::string& input_path) {
  rosbag::Bag input;
  try {
    input.open(input_path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw InputError("cannot read bag '" + input_path + "': " + e.what());
  }
  rosbag::View view(input);
  for (const rosbag::MessageInstance& m : view) {
    bag_->write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
  }
}

void ResultBag::close() {
  if (bag_ && bag_->isOpen()) bag_->close();
}

}  // namespace ros_bridge
}  // namespace fluoro_tracker
