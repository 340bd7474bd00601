// latency_benchmark: live latency of a running tracker_node. Publishes a trial bag's frames
// (image + camera_info) at a fixed rate, each stamped with the wall-clock time it is published,
// and measures, for every frame, the time from publishing to receiving the node's tf for it
// (tf carries the image stamp). Prints the median and 95th percentile latency, how many
// frames were answered, and the node's own count of dropped frames.
// Run it with the node by `roslaunch fluoro_tracker latency_benchmark.launch trial:=FOLDER`.
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <vector>

#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>

#include "fluoro_tracker/TrackingStatus.h"

namespace {

double percentile(std::vector<double> values, double fraction) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t k =
      std::min(values.size() - 1, static_cast<std::size_t>(fraction * (values.size() - 1) + 0.5));
  return values[k];
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "latency_benchmark");
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  std::string bag_path;
  std::string image_topic;
  double rate_hz = 30.0;
  double settle_s = 3.0;
  private_nh.param("bag", bag_path, std::string());
  private_nh.param("image_topic", image_topic, std::string("/fluoro/image_raw"));
  private_nh.param("rate_hz", rate_hz, 30.0);
  private_nh.param("settle_s", settle_s, 3.0);
  if (bag_path.empty() || !(rate_hz > 0.0)) {
    std::cerr << "latency_benchmark: set ~bag (a trial bag) and ~rate_hz > 0\n";
    return 2;
  }
  const std::string info_topic =
      image_topic.substr(0, image_topic.find_last_of('/')) + "/camera_info";

  // Every frame in memory first, so that reading the bag does not disturb the timing.
  std::vector<sensor_msgs::Image> images;
  std::vector<sensor_msgs::CameraInfo> infos;
  try {
    rosbag::Bag bag(bag_path);
    sensor_msgs::CameraInfo latest_info;
    bool have_info = false;
    for (const rosbag::MessageInstance& m :
         rosbag::View(bag, rosbag::TopicQuery({image_topic, info_topic}))) {
      if (const auto info = m.instantiate<sensor_msgs::CameraInfo>()) {
        latest_info = *info;
        have_info = true;
      } else if (const auto image = m.instantiate<sensor_msgs::Image>()) {
        if (!have_info) continue;
        images.push_back(*image);
        infos.push_back(latest_info);
      }
    }
  } catch (const rosbag::BagException& e) {
    std::cerr << "latency_benchmark: cannot read '" << bag_path << "': " << e.what() << "\n";
    return 2;
  }
  if (images.empty()) {
    std::cerr << "latency_benchmark: no frames on " << image_topic << " (with " << info_topic
              << ") in '" << bag_path << "'\n";
    return 2;
  }

  std::mutex mutex;
  std::map<ros::Time, ros::WallTime> published;  // image stamp -> publish time
  std::vector<ros::Time> stamps;                 // in publishing order
  std::map<ros::Time, double> latency_ms;        // image stamp -> first tf arrival
  std::uint32_t dropped = 0;
  std::size_t statuses = 0;
  auto tf_subscriber = nh.subscribe<tf2_msgs::TFMessage>(
      "/tf", 100, [&](const tf2_msgs::TFMessage::ConstPtr& message) {
        const ros::WallTime now = ros::WallTime::now();
        std::lock_guard<std::mutex> lock(mutex);
        for (const auto& t : message->transforms) {
          const auto it = published.find(t.header.stamp);
          if (it == published.end() || latency_ms.count(t.header.stamp)) continue;
          latency_ms[t.header.stamp] = 1e3 * (now - it->second).toSec();
        }
      });
  auto status_subscriber = nh.subscribe<fluoro_tracker::TrackingStatus>(
      "/tracker_node/status", 100, [&](const fluoro_tracker::TrackingStatus::ConstPtr& status) {
        std::lock_guard<std::mutex> lock(mutex);
        dropped = status->frames_dropped;
        ++statuses;
      });
  image_transport::ImageTransport transport(nh);
  image_transport::CameraPublisher publisher = transport.advertiseCamera(image_topic, 2);
  ros::AsyncSpinner spinner(2);
  spinner.start();

  // Wait for the tracking node to subscribe.
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(30.0);
  while (publisher.getNumSubscribers() == 0 && ros::ok() && ros::WallTime::now() < give_up) {
    ros::WallDuration(0.05).sleep();
  }
  if (publisher.getNumSubscribers() == 0) {
    std::cerr << "latency_benchmark: nothing subscribed to " << image_topic << " within 30 s\n";
    return 1;
  }
  ros::WallDuration(1.0).sleep();

  ros::WallRate rate(rate_hz);
  for (std::size_t i = 0; i < images.size() && ros::ok(); ++i) {
    const ros::WallTime now = ros::WallTime::now();
    const ros::Time stamp(now.sec, now.nsec);
    images[i].header.stamp = stamp;
    infos[i].header.stamp = stamp;
    {
      std::lock_guard<std::mutex> lock(mutex);
      published[stamp] = now;
      stamps.push_back(stamp);
    }
    publisher.publish(images[i], infos[i]);
    rate.sleep();
  }
  ros::WallDuration(settle_s).sleep();

  std::lock_guard<std::mutex> lock(mutex);
  std::vector<double> values;
  for (const auto& entry : latency_ms) values.push_back(entry.second);
  std::string unanswered;
  std::string slow;
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    const auto it = latency_ms.find(stamps[i]);
    if (it == latency_ms.end()) {
      unanswered += " " + std::to_string(i);
    } else if (it->second > 1e3 / rate_hz) {
      slow += " " + std::to_string(i);
    }
  }
  std::cout << std::fixed << std::setprecision(1) << "latency_benchmark: " << images.size()
            << " frames published at " << rate_hz << " Hz; tf received for " << values.size()
            << "; node statuses " << statuses << ", frames dropped (node's count) " << dropped
            << "\nlatency_benchmark: image publish -> tf: median " << percentile(values, 0.5)
            << " ms, p95 " << percentile(values, 0.95) << " ms, max "
            << (values.empty() ? 0.0 : *std::max_element(values.begin(), values.end())) << " ms\n";
  if (!unanswered.empty())
    std::cout << "latency_benchmark: frames without tf:" << unanswered << "\n";
  if (!slow.empty()) {
    std::cout << "latency_benchmark: frames answered after more than one frame period:" << slow
              << "\n";
  }
  ros::shutdown();
  return values.empty() ? 1 : 0;
}
