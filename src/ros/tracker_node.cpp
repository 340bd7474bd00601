#include "fluoro_tracker/ros/tracker_node.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <image_transport/camera_common.h>
#include <tf2_eigen/tf2_eigen.h>
#include <visualization_msgs/MarkerArray.h>

#include "fluoro_tracker/JointKinematics.h"
#include "fluoro_tracker/TrackingStatus.h"
#include "fluoro_tracker/imaging/contour_overlay.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/kinematics_csv.h"
#include "fluoro_tracker/io/poses_csv.h"
#include "fluoro_tracker/ros/bag_frame_reader.h"
#include "fluoro_tracker/ros/conversions.h"
#include "fluoro_tracker/ros/result_bag.h"
#include "fluoro_tracker/ros/tracking_messages.h"

namespace fluoro_tracker {
namespace ros_bridge {
namespace {}  // namespace

TrackerNode::TrackerNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      image_transport_(nh),
      private_image_transport_(private_nh),
      diagnostics_(nh, private_nh),
      tf_listener_(tf_buffer_) {
  std::string config_path;
  if (!private_nh_.getParam("config", config_path) || config_path.empty()) {
    throw InputError("the ~config parameter (the trial YAML) is required");
  }
  config_ = io::loadTrialConfig(config_path);
  models_ = io::loadTrialModels(config_);
  registration::RegistrationSettings settings = config_.registration;
  private_nh_.param("covariance", settings.compute_covariance, true);
  registrar_ = std::make_shared<registration::Registrar>(models_.bones, settings, models_.joints);
  initial_poses_ = config_.initialPoses();
  // The automatic search finds bones without an initial pose on the first frame and, with
  // ~recover, re-finds lost bones; otherwise it is built on the first ~reinitialize request
  // that asks for it (building its silhouette libraries takes about a second per bone).
  bool recover = false;
  private_nh_.param("recover", recover, false);
  if (initial_poses_.empty() || recover) {
    search_ = std::make_shared<registration::PoseSearch>(registrar_, config_.search);
  }
  tracker_ = std::make_unique<registration::Tracker>(registrar_, initial_poses_, search_);

  overlay_publisher_ = private_image_transport_.advertise("overlay", 1);
  kinematics_publisher_ = private_nh_.advertise<JointKinematics>("kinematics", 10);
  status_publisher_ = private_nh_.advertise<TrackingStatus>("status", 10);
  marker_publisher_ = private_nh_.advertise<visualization_msgs::MarkerArray>("markers", 2);
  play_bag_progress_publisher_ = private_nh_.advertise<PlayBagProgress>("play_bag_progress", 10);
  for (const auto& bone : config_.bones) {
    pose_publishers_.push_back(
        private_nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>(bone.name + "/pose", 10));
  }
  reinitialize_service_ =
      private_nh_.advertiseService("reinitialize", &TrackerNode::onReinitialize, this);
  play_bag_service_ = private_nh_.advertiseService("play_bag", &TrackerNode::onPlayBag, this);
  int queue_size = static_cast<int>(queue_size_);
  private_nh_.param("queue_size", queue_size, queue_size);
  if (queue_size < 1) {
    throw InputError("~queue_size must be at least 1 frame, not " + std::to_string(queue_size));
  }
  queue_size_ = static_cast<std::size_t>(queue_size);
  private_nh_.param("load_threshold_n", load_threshold_n_, 0.0);
  private_nh_.param("compression_sign", compression_sign_, -1.0);
  private_nh_.param("wrench_max_age_s", wrench_max_age_s_, 0.1);
  if (load_threshold_n_ > 0.0) {
    wrench_subscriber_ = nh_.subscribe("wrench", 10, &TrackerNode::onWrench, this);
  }
  publishLabTransform();
  int views = 1;
  private_nh_.param("views", views, 1);
  bool exact_sync = true;
  private_nh_.param("exact_sync", exact_sync, true);
  // image_transport would load the "compressed" transport from its plugin, which Debian does
  // not package; the node decodes those frames itself (CompressedImageFilter).
  std::string transport = "raw";
  private_nh_.param("image_transport", transport, transport);
  const bool compressed = transport == "compressed";
  const auto queue = static_cast<std::uint32_t>(queue_size);
  if (views == 1) {
    // The callback only converts and queues, so the subscriber's own queue rarely fills; as deep
    // as ours, a burst that ours can hold is not lost uncounted before it.
    std::string topic;
    if (compressed) {
      const std::string base = nh_.resolveName("image");
      compressed_filters_.push_back(std::make_unique<CompressedImageFilter>(nh_, base, queue));
      info_filters_.push_back(
          std::make_unique<message_filters::Subscriber<sensor_msgs::CameraInfo>>(
              nh_, image_transport::getCameraInfoTopic(base), queue));
      compressed_sync_ = std::make_unique<
          message_filters::TimeSynchronizer<sensor_msgs::Image, sensor_msgs::CameraInfo>>(
          *compressed_filters_[0], *info_filters_[0], queue);
      compressed_sync_->registerCallback(&TrackerNode::onImage, this);
      topic = compressed_filters_[0]->getTopic();
    } else {
      camera_subscriber_ =
          image_transport_.subscribeCamera("image", queue_size, &TrackerNode::onImage, this);
      topic = camera_subscriber_.getTopic();
    }
    ROS_INFO("tracker_node: tracking %zu bone(s) from '%s' on %s", config_.bones.size(),
             config_path.c_str(), topic.c_str());
  } else if (views == 2) {
    for (int v = 1; v <= 2; ++v) {
      const std::string prefix = "view_" + std::to_string(v) + "/";
      if (compressed) {
        compressed_filters_.push_back(
            std::make_unique<CompressedImageFilter>(nh_, nh_.resolveName(prefix + "image"), queue));
      } else {
        image_filters_.push_back(std::make_unique<image_transport::SubscriberFilter>(
            image_transport_, prefix + "image", queue_size));
      }
      info_filters_.push_back(
          std::make_unique<message_filters::Subscriber<sensor_msgs::CameraInfo>>(
              nh_, prefix + "camera_info", queue_size));
    }
    using ImageFilter = message_filters::SimpleFilter<sensor_msgs::Image>;
    const auto image_filter = [&](std::size_t v) -> ImageFilter& {
      if (compressed) return *compressed_filters_[v];
      return *image_filters_[v];
    };
    ImageFilter& view_1 = image_filter(0);
    ImageFilter& view_2 = image_filter(1);
    if (exact_sync) {
      exact_sync_ = std::make_unique<message_filters::Synchronizer<ExactPolicy>>(
          ExactPolicy(10), view_1, *info_filters_[0], view_2, *info_filters_[1]);
      exact_sync_->registerCallback(&TrackerNode::onTwoViews, this);
    } else {
      approximate_sync_ = std::make_unique<message_filters::Synchronizer<ApproximatePolicy>>(
          ApproximatePolicy(10), view_1, *info_filters_[0], view_2, *info_filters_[1]);
      approximate_sync_->registerCallback(&TrackerNode::onTwoViews, this);
    }
    ROS_INFO("tracker_node: tracking %zu bone(s) from '%s' on two views (%s sync%s)",
             config_.bones.size(), config_path.c_str(), exact_sync ? "exact" : "approximate",
             compressed ? ", compressed frames" : "");
  } else {
    throw InputError("~views must be 1 or 2, not " + std::to_string(views));
  }
  // After the subscriptions, whose filters it reads.
  diagnostics_.setHardwareID("fluoroscope");
  diagnostics_.add("tracking", this, &TrackerNode::diagnose);
  // Last: a constructor that throws must not leave a running thread behind.
  worker_ = std::thread(&TrackerNode::work, this);
}

void TrackerNode::publishLabTransform() {
  std::string lab_frame;
  private_nh_.param("lab_frame", lab_frame, std::string());
  if (lab_frame.empty() || lab_frame == "none") return;
  std::vector<double> values;
  private_nh_.param("lab_from_fluoroscope", values, std::vector<double>());
  const bool finite =
      std::all_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); });
  if (values.size() != 7 || !finite) {
    ROS_ERROR(
        "tracker_node: ~lab_from_fluoroscope must be 7 finite numbers (x y z in m, qx qy "
        "qz qw); no transform to '%s' is published",
        lab_frame.c_str());
    return;
  }
  const Eigen::Quaterniond rotation(values[6], values[3], values[4], values[5]);
  if (!(rotation.norm() > 1e-6)) {
    ROS_ERROR(
        "tracker_node: ~lab_from_fluoroscope's quaternion is zero; no transform to '%s' "
        "is published",
        lab_frame.c_str());
    return;
  }
  if (config_.fixed_frame.empty()) {
    ROS_ERROR(
        "tracker_node: ~lab_frame needs the trial's fixed_frame (e.g. fluoro_optical) to "
        "know which frame to place in '%s'; no transform is published",
        lab_frame.c_str());
    return;
  }
  if (lab_frame == config_.fixed_frame) {
    ROS_ERROR(
        "tracker_node: ~lab_frame '%s' is the trial's fixed frame itself; no transform is "
        "published",
        lab_frame.c_str());
    return;
  }
  geometry_msgs::TransformStamped transform;
  transform.header.stamp = ros::Time::now();  // static: the stamp is not used for lookups
  transform.header.frame_id = lab_frame;
  transform.child_frame_id = config_.fixed_frame;
  transform.transform = toTransformMessage(
      geometry::makePose(rotation.normalized(), Eigen::Vector3d(values[0], values[1], values[2])));
  static_tf_broadcaster_.sendTransform(transform);
  ROS_INFO("tracker_node: '%s' placed in the lab frame '%s'", config_.fixed_frame.c_str(),
           lab_frame.c_str());
}

TrackerNode::~TrackerNode() {
  camera_subscriber_.shutdown();
  for (auto& filter : compressed_filters_) filter->shutdown();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stopping_ = true;
  }
  queue_ready_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void TrackerNode::onImage(const sensor_msgs::ImageConstPtr& image,
                          const sensor_msgs::CameraInfoConstPtr& info) {
  enqueue({image}, {info});
}

void TrackerNode::onTwoViews(const sensor_msgs::ImageConstPtr& image1,
                             const sensor_msgs::CameraInfoConstPtr& info1,
                             const sensor_msgs::ImageConstPtr& image2,
                             const sensor_msgs::CameraInfoConstPtr& info2) {
  enqueue({image1, image2}, {info1, info2});
}

void TrackerNode::enqueue(const std::vector<sensor_msgs::ImageConstPtr>& images,
                          const std::vector<sensor_msgs::CameraInfoConstPtr>& infos) {
  PendingFrame frame;
  for (std::size_t v = 0; v < images.size(); ++v) {
    try {
      frame.images.push_back(fromImageMessage(*images[v]));
    } catch (const InputError& e) {
      ROS_ERROR_THROTTLE(5.0, "tracker_node: frame at %.3f skipped: %s",
                         images[v]->header.stamp.toSec(), e.what());
      return;
    }
    frame.infos.push_back(*infos[v]);
  }
  frame.header = images.front()->header;
  double dropped_stamp = -1.0;
  std::size_t waiting = 0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (pending_.size() >= queue_size_) {
      // Full: the oldest waiting frame goes, so that the newest are tracked without delay.
      dropped_stamp = pending_.front().header.stamp.toSec();
      pending_.pop_front();
      ++frames_dropped_;
    }
    pending_.push_back(std::move(frame));
    waiting = pending_.size();
  }
  queue_ready_.notify_one();
  if (dropped_stamp >= 0.0 && queue_size_ > 1) {
    ROS_WARN_THROTTLE(5.0,
                      "tracker_node: %zu frames waiting, the queue is full: dropped the frame at "
                      "%.3f (frames arrive faster than they are tracked; raise ~queue_size to "
                      "keep them)",
                      waiting, dropped_stamp);
  }
}

void TrackerNode::work() {
  while (true) {
    PendingFrame frame;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_ready_.wait(lock, [this] { return stopping_ || !pending_.empty(); });
      if (stopping_) return;
      frame = std::move(pending_.front());
      pending_.pop_front();
    }
    process(frame);
  }
}

void TrackerNode::process(const PendingFrame& frame) {
  // Frames are tracked in arrival order. One stamped no later than the last tracked frame is
  // still tracked (no data is lost), from the last result, but said: its motion prediction
  // runs the wrong way, and tf listeners ignore a transform whose stamp repeats.
  if (!last_stamp_.isZero() && frame.header.stamp <= last_stamp_) {
    ROS_WARN_THROTTLE(5.0,
                      "tracker_node: out-of-order stamps: the frame at %.6f is not newer than the "
                      "last tracked frame at %.6f; tracked anyway",
                      frame.header.stamp.toSec(), last_stamp_.toSec());
  }
  last_stamp_ = std::max(last_stamp_, frame.header.stamp);
  std::vector<registration::ViewImage> views;
  std::string fixed_frame;
  if (rectifiers_.size() < frame.images.size()) rectifiers_.resize(frame.images.size());
  try {
    for (std::size_t v = 0; v < frame.images.size(); ++v) {
      // The same calibration comes with every frame: its distortion maps are built once.
      std::optional<ViewRectifier>& rectifier = rectifiers_[v];
      if (!rectifier || !rectifier->sameCalibration(frame.infos[v])) {
        rectifier.emplace(frame.infos[v]);
      }
      geometry::XrayCamera camera = rectifier->camera();
      const cv::Mat image = rectifier->rectify(frame.images[v]);
      if (v == 0)
        fixed_frame = config_.fixed_frame.empty() ? camera.frameId() : config_.fixed_frame;
      if (fixed_frame != camera.frameId()) {
        try {
          const auto transform = tf_buffer_.lookupTransform(fixed_frame, camera.frameId(),
                                                            frame.header.stamp, ros::Duration(0.2));
          camera.setWorldFromCamera(tf2::transformToEigen(transform));
        } catch (const tf2::TransformException& e) {
          throw InputError("no transform " + fixed_frame + " <- " + camera.frameId() + ": " +
                           e.what());
        }
      }
      views.push_back({image, camera});
    }
  } catch (const InputError& e) {
    ROS_ERROR_THROTTLE(5.0, "tracker_node: frame at %.3f skipped: %s", frame.header.stamp.toSec(),
                       e.what());
    return;
  }

  const double force_n = compressiveForceAt(frame.header.stamp);
  const bool loaded = load_threshold_n_ > 0.0 && force_n > load_threshold_n_;
  registration::TrackedFrame tracked;
  {
    std::lock_guard<std::mutex> lock(tracker_mutex_);
    try {
      tracked = tracker_->track(views, std::vector<bool>(registrar_->joints().size(), loaded));
    } catch (const InputError& e) {
      ROS_ERROR_THROTTLE(5.0, "tracker_node: frame at %.3f not tracked: %s",
                         frame.header.stamp.toSec(), e.what());
      return;
    }
  }
  const std::string jump = registration::describeImplausibleJumps(tracked, registrar_->bones());
  if (!jump.empty()) {
    ROS_WARN_THROTTLE(5.0, "tracker_node: frame at %.3f: %s", frame.header.stamp.toSec(),
                      jump.c_str());
  }
  if (!tracked.given_up.empty()) {
    ROS_WARN_THROTTLE(5.0, "tracker_node: frame at %.3f given up, every bone lost: %s",
                      frame.header.stamp.toSec(), tracked.given_up.c_str());
  }
  const auto& bones = registrar_->bones();
  const auto transforms = boneTransforms(frame.header.stamp, fixed_frame, *registrar_, tracked);
  tf_broadcaster_.sendTransform(transforms);
  for (std::size_t b = 0; b < bones.size(); ++b) {
    geometry_msgs::PoseWithCovarianceStamped pose;
    pose.header.stamp = frame.header.stamp;
    pose.header.frame_id = fixed_frame;
    pose.pose.pose = toPoseMessage(tracked.poses[b]);
    const bool valid = b < tracked.result.covariance_valid.size() &&
                       tracked.result.covariance_valid[b] && tracked.status[b] == "ok";
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) {
        // Unknown: -1 on the diagonal's first element, as REP-145-style consumers expect.
        pose.pose.covariance[6 * r + c] =
            valid ? tracked.result.covariances[b](r, c) : (r == 0 && c == 0 ? -1.0 : 0.0);
      }
    }
    pose_publishers_[b].publish(pose);
  }

  std::vector<JointKinematics> kinematics;
  for (std::size_t j = 0; j < registrar_->joints().size(); ++j) {
    JointKinematics message;
    if (kinematicsMessage(frame.header.stamp, *registrar_, j, tracked, force_n, loaded, &message)) {
      kinematics_publisher_.publish(message);
      kinematics.push_back(message);
    }
  }

  std::uint32_t dropped = 0;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    dropped = frames_dropped_;
  }
  const TrackingStatus status = statusMessage(frame.header, *registrar_, tracked, dropped);
  status_publisher_.publish(status);
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    ++frames_tracked_;
    for (const auto& s : tracked.status) frames_lost_ += s == "ok" ? 0 : 1;
    last_solve_seconds_ = tracked.solve_seconds;
  }
  diagnostics_.update();
  if (marker_publisher_.getNumSubscribers() > 0) {
    publishMarkers(frame.header, fixed_frame, tracked, kinematics);
  }

  if (overlay_publisher_.getNumSubscribers() > 0) {
    std::vector<const imaging::SilhouetteModel*> models;
    for (const auto& bone : bones) models.push_back(bone.silhouette.get());
    overlay_publisher_.publish(
        cv_bridge::CvImage(
            frame.header, "bgr8",
            imaging::drawContourOverlay(views[0].image, views[0].camera, models, tracked.poses))
            .toImageMsg());
  }
}

void TrackerNode::publishMarkers(const std_msgs::Header& header, const std::string& fixed_frame,
                                 const registration::TrackedFrame& tracked,
                                 const std::vector<JointKinematics>& kinematics) {
  visualization_msgs::MarkerArray markers;
  const auto& bones = registrar_->bones();
  auto marker = [&](const std::string& ns, std::size_t id, int type) {
    visualization_msgs::Marker m;
    m.header.stamp = header.stamp;
    m.header.frame_id = fixed_frame;
    m.ns = ns;
    m.id = static_cast<int>(id);
    m.type = type;
    return m;
  };
  auto colour = [](float r, float g, float b, float a) {
    std_msgs::ColorRGBA c;
    c.r = r;
    c.g = g;
    c.b = b;
    c.a = a;
    return c;
  };
  const std_msgs::ColorRGBA colours[] = {colour(0.2f, 0.9f, 0.2f, 0.8f),
                                         colour(1.0f, 0.6f, 0.1f, 0.8f)};
  for (std::size_t b = 0; b < bones.size(); ++b) {
    visualization_msgs::Marker m = marker("bones", b, visualization_msgs::Marker::MESH_RESOURCE);
    m.mesh_resource = "file://" + config_.bones[b].mesh;
    const double scale = geometry::metresPerUnit(config_.bones[b].mesh_units);
    m.scale.x = m.scale.y = m.scale.z = scale;
    m.pose = toPoseMessage(tracked.poses[b]);
    m.color = colours[b % 2];
    markers.markers.push_back(m);
  }
  for (std::size_t j = 0; j < tracked.result.joints.size(); ++j) {
    const auto& joint = tracked.result.joints[j];
    visualization_msgs::Marker m =
        marker("contact_points", j, visualization_msgs::Marker::SPHERE_LIST);
    m.pose.orientation.w = 1.0;
    m.scale.x = m.scale.y = m.scale.z = 0.001;
    m.color = colour(1.0f, 0.0f, 0.0f, 1.0f);
    for (const auto& point : joint.contact.points) {
      geometry_msgs::Point p;
      p.x = point.position.x();
      p.y = point.position.y();
      p.z = point.position.z();
      m.points.push_back(p);
    }
    m.action =
        m.points.empty() ? visualization_msgs::Marker::DELETE : visualization_msgs::Marker::ADD;
    markers.markers.push_back(m);
  }
  // Each joint's coordinates as a label 8 cm from its child bone along the fixed frame's -Y
  // (above it in the usual optical fixed frame, image up), clear of the meshes.
  for (std::size_t j = 0; j < kinematics.size(); ++j) {
    visualization_msgs::Marker m =
        marker("kinematics", j, visualization_msgs::Marker::TEXT_VIEW_FACING);
    const auto& joint = registrar_->joints()[j];
    Eigen::Vector3d at = tracked.poses[joint.child].translation();
    at.y() -= 0.08 + 0.03 * static_cast<double>(j);
    m.pose = toPoseMessage(geometry::Pose(Eigen::Translation3d(at)));
    m.scale.z = 0.007;
    m.color = colour(1.0f, 1.0f, 1.0f, 1.0f);
    m.text = kinematicsLabel(kinematics[j]);
    markers.markers.push_back(m);
  }
  marker_publisher_.publish(markers);
}

void TrackerNode::onWrench(const geometry_msgs::WrenchStamped::ConstPtr& wrench) {
  if (!std::isfinite(wrench->wrench.force.z)) {
    ROS_WARN_THROTTLE(5.0, "tracker_node: a wrench with a non-finite force was ignored");
    return;
  }
  std::lock_guard<std::mutex> lock(wrench_mutex_);
  last_wrench_ = *wrench;
}

double TrackerNode::compressiveForceAt(const ros::Time& stamp) {
  std::lock_guard<std::mutex> lock(wrench_mutex_);
  if (!last_wrench_) return 0.0;
  if (std::abs((last_wrench_->header.stamp - stamp).toSec()) > wrench_max_age_s_) return 0.0;
  return std::max(0.0, compression_sign_ * last_wrench_->wrench.force.z);
}

void TrackerNode::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  if (frames_tracked_ == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no frame tracked yet");
  } else if (frames_lost_ > 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "some bones were lost");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "tracking");
  }
  status.add("frames tracked", frames_tracked_);
  status.add("frames dropped (tracker busy)", frames_dropped_);
  status.add("frames waiting", pending_.size());
  status.add("bone-frames lost", frames_lost_);
  if (!compressed_filters_.empty()) {
    std::size_t undecodable = 0;
    for (const auto& filter : compressed_filters_) undecodable += filter->skipped();
    status.add("compressed frames that did not decode", undecodable);
  }
  status.add("last solve time (s)", last_solve_seconds_);
}

bool TrackerNode::onReinitialize(Reinitialize::Request& request, Reinitialize::Response& response) {
  try {
    std::lock_guard<std::mutex> lock(tracker_mutex_);
    if (request.automatic) {
      if (!search_)
        search_ = std::make_shared<registration::PoseSearch>(registrar_, config_.search);
      if (!tracker_->canSearch()) tracker_->setSearch(search_);
      tracker_->requestSearch();
      response.success = true;
      response.message = "every bone will be searched for automatically on the next frame";
      return true;
    }
    if (request.bones.empty() && request.poses.empty() && initial_poses_.empty()) {
      if (!tracker_->canSearch()) tracker_->setSearch(search_);
      tracker_->requestSearch();
      response.message = "the trial has no initial poses: searching on the next frame";
    } else if (request.bones.empty() && request.poses.empty()) {
      std::vector<std::string> names;
      for (const auto& bone : registrar_->bones()) names.push_back(bone.name);
      tracker_->reinitialize(names, initial_poses_);
      response.message = "all bones reset to the trial's initial poses";
    } else {
      std::vector<geometry::Pose> poses;
      for (const auto& p : request.poses) poses.push_back(fromPoseMessage(p));
      tracker_->reinitialize(request.bones, poses);
      response.message = "set " + std::to_string(request.bones.size()) + " bone pose(s)";
    }
    response.success = true;
  } catch (const InputError& e) {
    response.success = false;
    response.message = e.what();
  }
  return true;
}

bool TrackerNode::onPlayBag(PlayBag::Request& request, PlayBag::Response& response) {
  response.success = false;
  try {
    const auto start = std::chrono::steady_clock::now();
    std::unique_ptr<ResultBag> result_bag;
    if (!request.output_bag_path.empty()) {
      result_bag = std::make_unique<ResultBag>(request.output_bag_path);
    }
    BagFrameReader reader(request.bag_path, request.image_topics, config_.fixed_frame);
    // Searches as the live tracker does (always when the trial has no initial poses).
    std::shared_ptr<const registration::PoseSearch> search;
    {
      std::lock_guard<std::mutex> lock(tracker_mutex_);
      if (tracker_->canSearch()) search = search_;
    }
    registration::Tracker tracker(registrar_, initial_poses_, search);
    const auto& bones = registrar_->bones();
    std::vector<io::PoseRecord> poses;
    std::vector<io::KinematicsRecord> kinematics;
    std::uint32_t frames = 0;
    std::uint32_t tracked_frames = 0;
    PlayBagProgress progress;
    progress.bag_path = request.bag_path;
    progress.frames_expected = static_cast<std::uint32_t>(reader.expectedFrames());
    const auto publishProgress = [&](double stamp_s, bool done) {
      if (stamp_s > 0.0) progress.header.stamp.fromSec(stamp_s);
      progress.frames_read = frames;
      progress.frames_tracked = tracked_frames;
      progress.done = done;
      play_bag_progress_publisher_.publish(progress);
    };
    reader.read(
        [&](const BagFrame& frame) {
          ++frames;
          std::vector<registration::ViewImage> views;
          for (std::size_t v = 0; v < frame.images.size(); ++v) {
            views.push_back({frame.images[v], frame.cameras[v]});
          }
          registration::TrackedFrame tracked;
          try {
            tracked = tracker.track(views);
          } catch (const InputError& e) {
            ROS_WARN("tracker_node: play_bag frame %d not tracked: %s", frame.index, e.what());
            publishProgress(frame.stamp_s, false);
            return;
          }
          const std::string jump =
              registration::describeImplausibleJumps(tracked, registrar_->bones());
          if (!jump.empty())
            ROS_WARN("tracker_node: play_bag frame %d: %s", frame.index, jump.c_str());
          if (!tracked.given_up.empty()) {
            ROS_WARN("tracker_node: play_bag frame %d given up, every bone lost: %s", frame.index,
                     tracked.given_up.c_str());
          }
          ++tracked_frames;
          if (result_bag)
            result_bag->addFrame(frame.stamp_s, reader.fixedFrame(), *registrar_, tracked);
          for (std::size_t b = 0; b < bones.size(); ++b) {
            io::PoseRecord record{frame.index,      frame.stamp_s,     bones[b].name,
                                  tracked.poses[b], tracked.status[b], std::nullopt};
            if (b < tracked.result.quality.size()) record.quality = tracked.result.quality[b];
            poses.push_back(record);
          }
          for (std::size_t j = 0; j < registrar_->joints().size(); ++j) {
            const auto& joint = registrar_->joints()[j];
            kinematics.push_back({frame.index, frame.stamp_s, joint.name,
                                  jointCoordinates(*registrar_, j, tracked),
                                  jointStatus(*registrar_, j, tracked)});
          }
          if (frames % 50 == 0) {
            ROS_INFO("tracker_node: play_bag frame %u of %u", frames, progress.frames_expected);
          }
          publishProgress(frame.stamp_s, false);
        },
        [&](int index, double stamp_s, const std::string& reason) {
          ++frames;
          ROS_WARN("tracker_node: play_bag skipped frame %d: %s", index, reason.c_str());
          publishProgress(stamp_s, false);
        });
    publishProgress(0.0, true);
    if (result_bag) {
      result_bag->copyInput(request.bag_path);
      result_bag->close();
    }
    if (!request.poses_csv_path.empty()) io::writePosesCsv(request.poses_csv_path, poses);
    if (!request.kinematics_csv_path.empty()) {
      io::writeKinematicsCsv(request.kinematics_csv_path, kinematics);
    }
    response.frames = frames;
    response.frames_tracked = tracked_frames;
    response.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    response.success = true;
    response.message = "tracked " + std::to_string(tracked_frames) + " of " +
                       std::to_string(frames) + " frame(s) of '" + request.bag_path + "'";
  } catch (const std::exception& e) {
    response.message = e.what();
  }
  return true;
}

}  // namespace ros_bridge
}  // namespace fluoro_tracker
