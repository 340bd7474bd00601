// The tracking node as a nodelet: the same TrackerNode class, loaded into a nodelet manager so
// that images reach it without serialisation (e.g. from a camera driver nodelet).
#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "fluoro_tracker/ros/tracker_node.h"

namespace fluoro_tracker {
namespace ros_bridge {

class TrackerNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      node_ = std::make_unique<TrackerNode>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      NODELET_FATAL("tracker_nodelet: %s", e.what());
    }
  }

  std::unique_ptr<TrackerNode> node_;
};

}  // namespace ros_bridge
}  // namespace fluoro_tracker

PLUGINLIB_EXPORT_CLASS(fluoro_tracker::ros_bridge::TrackerNodelet, nodelet::Nodelet)
