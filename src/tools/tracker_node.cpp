// tracker_node: the tracking node (see ros/tracker_node.h and docs/interfaces.md).
#include <ros/ros.h>

#include "fluoro_tracker/ros/tracker_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "tracker_node");
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  try {
    fluoro_tracker::ros_bridge::TrackerNode node(nh, private_nh);
    // Two threads: a long ~play_bag call does not stop the image callbacks.
    ros::AsyncSpinner spinner(2);
    spinner.start();
    ros::waitForShutdown();
  } catch (const std::exception& e) {
    ROS_FATAL("tracker_node: %s", e.what());
    return 1;
  }
  return 0;
}
