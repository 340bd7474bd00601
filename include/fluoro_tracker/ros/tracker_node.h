#pragma once

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <tuple>

#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/WrenchStamped.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <message_filters/time_synchronizer.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include "fluoro_tracker/JointKinematics.h"
#include "fluoro_tracker/PlayBag.h"
#include "fluoro_tracker/PlayBagProgress.h"
#include "fluoro_tracker/Reinitialize.h"
#include "fluoro_tracker/io/trial_config.h"
#include "fluoro_tracker/io/trial_models.h"
#include "fluoro_tracker/registration/tracker.h"
#include "fluoro_tracker/ros/compressed_image_filter.h"
#include "fluoro_tracker/ros/view_rectifier.h"

namespace fluoro_tracker {
namespace ros_bridge {

// The tracking node (docs/interfaces.md): a thin ROS wrapper around registration::Tracker.
// One view through an image_transport camera subscription (`image` + its `camera_info`; with
// ~image_transport: compressed, `image/compressed` decoded by the node itself), or
// two (bi-plane, ~views: 2) through `view_1/image`, `view_1/camera_info`, `view_2/...`
// synchronised by message_filters (exact stamps, or approximate with ~exact_sync: false).
// Frames are registered in order on a worker thread from a queue of ~queue_size frames (30 by
// default, a second at 30 Hz, so that a replayed trial loses no frame to a few slow ones); when
// the queue is full the oldest waiting frame is dropped, counted and logged (~queue_size: 1
// keeps only the latest, for the lowest latency on a live stream). Publishes tf fixed_frame ->
// <bone> stamped with the image stamp, ~kinematics, ~status, ~overlay, ~markers (bone meshes and
// contact points) and diagnostics; serves ~reinitialize and ~play_bag. Bad input is logged with its
// reason; the node keeps running and publishes nothing non-finite.
class TrackerNode {
 public:
  // Reads ~config (the trial YAML). Throws InputError for a missing or bad config.
  TrackerNode(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~TrackerNode();

  TrackerNode(const TrackerNode&) = delete;
  TrackerNode& operator=(const TrackerNode&) = delete;

 private:
  struct PendingFrame {
    std::vector<cv::Mat> images;  // one per view
    std::vector<sensor_msgs::CameraInfo> infos;
    std_msgs::Header header;  // the first view's
  };
  using ExactPolicy =
      message_filters::sync_policies::ExactTime<sensor_msgs::Image, sensor_msgs::CameraInfo,
                                                sensor_msgs::Image, sensor_msgs::CameraInfo>;
  using ApproximatePolicy =
      message_filters::sync_policies::ApproximateTime<sensor_msgs::Image, sensor_msgs::CameraInfo,
                                                      sensor_msgs::Image, sensor_msgs::CameraInfo>;

  void onImage(const sensor_msgs::ImageConstPtr& image,
               const sensor_msgs::CameraInfoConstPtr& info);
  void onTwoViews(const sensor_msgs::ImageConstPtr& image1,
                  const sensor_msgs::CameraInfoConstPtr& info1,
                  const sensor_msgs::ImageConstPtr& image2,
                  const sensor_msgs::CameraInfoConstPtr& info2);
  void enqueue(const std::vector<sensor_msgs::ImageConstPtr>& images,
               const std::vector<sensor_msgs::CameraInfoConstPtr>& infos);
  void work();
  void process(const PendingFrame& frame);
  void publishMarkers(const std_msgs::Header& header, const std::string& fixed_frame,
                      const registration::TrackedFrame& tracked,
                      const std::vector<JointKinematics>& kinematics);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);
  // Publishes ~lab_frame -> the trial's fixed frame from ~lab_from_fluoroscope on /tf_static
  // (e.g. the fluoroscope's calibration in a motion-capture lab); logs bad parameters.
  void publishLabTransform();
  void onWrench(const geometry_msgs::WrenchStamped::ConstPtr& wrench);
  // The compressive force (N) measured near `stamp`, or 0 if none is recent enough.
  double compressiveForceAt(const ros::Time& stamp);
  bool onReinitialize(Reinitialize::Request& request, Reinitialize::Response& response);
  bool onPlayBag(PlayBag::Request& request, PlayBag::Response& response);

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  io::TrialConfig config_;
  io::TrialModels models_;
  std::shared_ptr<const registration::Registrar> registrar_;
  std::vector<geometry::Pose> initial_poses_;

  // Per view, the camera of the latest camera_info and the removal of its lens distortion
  // (the worker's alone).
  std::vector<std::optional<ViewRectifier>> rectifiers_;

  std::mutex tracker_mutex_;  // the tracker is shared by the worker and the services
  std::unique_ptr<registration::Tracker> tracker_;
  std::shared_ptr<registration::PoseSearch> search_;  // built when needed (see the constructor)

  image_transport::ImageTransport image_transport_;
  image_transport::ImageTransport private_image_transport_;  // for ~overlay
  image_transport::CameraSubscriber camera_subscriber_;      // one view
  // Two views (~views: 2): view_1/image, view_1/camera_info, view_2/..., synchronised exactly
  // or approximately (~exact_sync).
  std::vector<std::unique_ptr<image_transport::SubscriberFilter>> image_filters_;
  // With ~image_transport: compressed, each view's frames through CompressedImageFilter instead
  // (no plugin needed), one view's synchronised with its camera_info by compressed_sync_.
  std::vector<std::unique_ptr<CompressedImageFilter>> compressed_filters_;
  std::vector<std::unique_ptr<message_filters::Subscriber<sensor_msgs::CameraInfo>>> info_filters_;
  // The synchronisers after the filters they connect: destroyed first, they disconnect from
  // filters still alive.
  std::unique_ptr<message_filters::TimeSynchronizer<sensor_msgs::Image, sensor_msgs::CameraInfo>>
      compressed_sync_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy>> exact_sync_;
  std::unique_ptr<message_filters::Synchronizer<ApproximatePolicy>> approximate_sync_;
  image_transport::Publisher overlay_publisher_;
  ros::Publisher kinematics_publisher_;
  ros::Publisher status_publisher_;
  ros::Publisher marker_publisher_;
  ros::Publisher play_bag_progress_publisher_;
  std::vector<ros::Publisher> pose_publishers_;  // ~<bone>/pose, with covariance
  diagnostic_updater::Updater diagnostics_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  tf2_ros::StaticTransformBroadcaster static_tf_broadcaster_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::ServiceServer reinitialize_service_;
  // Optional joint load (`wrench`, e.g. an instrumented tray or force plate): when the
  // compressive force, compression_sign x force.z, exceeds ~load_threshold_n within
  // ~wrench_max_age_s of an image, every joint's loaded (stay-in-contact) term joins.
  ros::Subscriber wrench_subscriber_;
  double load_threshold_n_ = 0.0;  // <= 0: no wrench input
  double compression_sign_ = -1.0;
  double wrench_max_age_s_ = 0.1;
  std::mutex wrench_mutex_;
  std::optional<geometry_msgs::WrenchStamped> last_wrench_;
  ros::ServiceServer play_bag_service_;

  std::mutex queue_mutex_;
  std::condition_variable queue_ready_;
  std::deque<PendingFrame> pending_;  // oldest first
  std::size_t queue_size_ = 30;       // ~queue_size
  std::uint32_t frames_dropped_ = 0;
  // For diagnostics (worker thread only, read under queue_mutex_).
  std::uint32_t frames_tracked_ = 0;
  std::uint32_t frames_lost_ = 0;
  double last_solve_seconds_ = 0.0;
  ros::Time last_stamp_;  // the newest stamp tracked (worker thread only)
  bool stopping_ = false;
  std::thread worker_;
};

}  // namespace ros_bridge
}  // namespace fluoro_tracker
