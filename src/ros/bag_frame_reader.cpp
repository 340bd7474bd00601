#include "fluoro_tracker/ros/bag_frame_reader.h"

#include <filesystem>
#include <set>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <tf2/buffer_core.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/ros/conversions.h"
#include "fluoro_tracker/ros/view_rectifier.h"

namespace fluoro_tracker {
namespace ros_bridge {

namespace {

const std::string kRawType = "sensor_msgs/Image";
const std::string kCompressedType = "sensor_msgs/CompressedImage";
const std::string kCompressedSuffix = "/compressed";

// image_transport's name for a stream: ".../image_raw" for ".../image_raw/compressed".
std::string baseTopic(const std::string& image_topic, bool compressed) {
  const std::size_t n = kCompressedSuffix.size();
  if (compressed && image_topic.size() > n &&
      image_topic.compare(image_topic.size() - n, n, kCompressedSuffix) == 0) {
    return image_topic.substr(0, image_topic.size() - n);
  }
  return image_topic;
}

std::string siblingInfoTopic(const std::string& image_topic) {
  const auto slash = image_topic.rfind('/');
  return (slash == std::string::npos ? std::string() : image_topic.substr(0, slash)) +
         "/camera_info";
}

// One image message of either type, kept until its view's camera_info has arrived.
struct ImageMessage {
  sensor_msgs::Image::ConstPtr raw;
  sensor_msgs::CompressedImage::ConstPtr compressed;

  const std_msgs::Header& header() const { return raw ? raw->header : compressed->header; }
  // Throws InputError for an encoding or compressed data that is not a grey frame.
  cv::Mat decode() const {
    return raw ? fromImageMessage(*raw) : fromCompressedImageMessage(*compressed);
  }
};

}  // namespace

struct BagFrameReader::Impl {
  rosbag::Bag bag;
  std::vector<std::string> info_topics;
  std::vector<bool> compressed;  // per view: sensor_msgs/CompressedImage
  tf2::BufferCore static_tf{ros::Duration(1e6)};
};

BagFrameReader::BagFrameReader(const std::string& bag_path, std::vector<std::string> image_topics,
                               std::string fixed_frame)
    : impl_(std::make_unique<Impl>()),
      image_topics_(std::move(image_topics)),
      fixed_frame_(std::move(fixed_frame)) {
  if (!std::filesystem::exists(bag_path)) throw InputError("bag '" + bag_path + "' does not exist");
  try {
    impl_->bag.open(bag_path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw InputError("bag '" + bag_path + "' cannot be read: " + e.what());
  }
  rosbag::View all(impl_->bag);
  std::set<std::string> topics;
  std::map<std::string, std::string> types;
  for (const rosbag::ConnectionInfo* c : all.getConnections()) {
    topics.insert(c->topic);
    types[c->topic] = c->datatype;
  }
  if (image_topics_.empty()) {
    // Every camera stream once: its raw images, or its compressed ones when the bag has only
    // those (a bag recorded from image_transport's compressed transport).
    for (const auto& [topic, type] : types) {
      if (type == kRawType) image_topics_.push_back(topic);
    }
    for (const auto& [topic, type] : types) {
      if (type == kCompressedType) {
        const auto base = types.find(baseTopic(topic, true));
        if (base == types.end() || base->second != kRawType) image_topics_.push_back(topic);
      }
    }
  }
  if (image_topics_.empty()) {
    throw InputError("bag '" + bag_path + "' has no " + kRawType + " or " + kCompressedType +
                     " topic");
  }
  for (const auto& topic : image_topics_) {
    if (!topics.count(topic))
      throw InputError("bag '" + bag_path + "' has no topic '" + topic + "'");
    if (types[topic] != kRawType && types[topic] != kCompressedType) {
      throw InputError("topic '" + topic + "' in bag '" + bag_path + "' carries " + types[topic] +
                       ", not " + kRawType + " or " + kCompressedType);
    }
    const bool compressed = types[topic] == kCompressedType;
    impl_->compressed.push_back(compressed);
    const std::string info = siblingInfoTopic(baseTopic(topic, compressed));
    if (!topics.count(info)) {
      throw InputError("bag '" + bag_path + "' has no camera_info for '" + topic + "' (expected '" +
                       info + "')");
    }
    impl_->info_topics.push_back(info);
  }
  expected_frames_ = rosbag::View(impl_->bag, rosbag::TopicQuery(image_topics_[0])).size();
  for (const rosbag::MessageInstance& m :
       rosbag::View(impl_->bag, rosbag::TopicQuery(std::vector<std::string>{"/tf_static"}))) {
    if (const auto tf = m.instantiate<tf2_msgs::TFMessage>()) {
      for (const auto& t : tf->transforms) impl_->static_tf.setTransform(t, "bag", true);
    }
  }
}

BagFrameReader::~BagFrameReader() = default;

void BagFrameReader::read(const FrameCallback& consume, const SkipCallback& skipped) {
  const std::size_t views = image_topics_.size();
  // Per view, the camera of its latest camera_info (and the removal of its lens distortion).
  std::vector<std::optional<ViewRectifier>> info(views);
  std::vector<std::string> info_problem(views);  // why the latest camera_info was rejected
  struct Pending {
    int index = 0;
    std::vector<cv::Mat> images;
    std::vector<geometry::XrayCamera> cameras;
    std::size_t filled = 0;
    std::string problem;
  };
  std::map<double, Pending> pending;  // by header stamp
  int next_index = 0;

  std::vector<std::string> topics = image_topics_;
  topics.insert(topics.end(), impl_->info_topics.begin(), impl_->info_topics.end());
  rosbag::View view(impl_->bag, rosbag::TopicQuery(topics));
  const auto flushOlderThan = [&](double stamp) {
    // Frames older than `stamp` that still miss a view will not be completed.
    while (!pending.empty() && pending.begin()->first < stamp && views > 1) {
      const auto& [s, p] = *pending.begin();
      skipped(p.index, s, p.problem.empty() ? "a view has no image at this stamp" : p.problem);
      pending.erase(pending.begin());
    }
  };
  // Images that arrived before any camera_info of their view (in a bag, an image and the
  // camera_info of the same stamp come in either order): held until the camera_info arrives.
  std::vector<std::vector<ImageMessage>> waiting(views);
  const auto handleImage = [&](std::size_t v, const ImageMessage& msg) {
    const std_msgs::Header& header = msg.header();
    const double stamp = header.stamp.toSec();
    auto it = pending.find(stamp);
    if (it == pending.end()) {
      flushOlderThan(stamp);
      Pending p;
      p.index = next_index++;
      p.images.resize(views);
      p.cameras.resize(views);
      it = pending.emplace(stamp, std::move(p)).first;
    }
    Pending& p = it->second;
    try {
      if (!info[v]) {
        throw InputError("no valid camera_info on '" + impl_->info_topics[v] + "' for this image" +
                         (info_problem[v].empty() ? "" : " (" + info_problem[v] + ")"));
      }
      geometry::XrayCamera camera = info[v]->camera();
      cv::Mat image = msg.decode();
      if (image.cols != camera.width() || image.rows != camera.height()) {
        throw InputError("image on '" + image_topics_[v] + "' is " + std::to_string(image.cols) +
                         "x" + std::to_string(image.rows) + " but its camera_info says " +
                         std::to_string(camera.width()) + "x" + std::to_string(camera.height()));
      }
      if (!header.frame_id.empty()) camera.setFrameId(header.frame_id);
      if (fixed_frame_.empty()) fixed_frame_ = camera.frameId();
      if (camera.frameId() != fixed_frame_) {
        try {
          const auto t =
              impl_->static_tf.lookupTransform(fixed_frame_, camera.frameId(), ros::Time(0));
          camera.setWorldFromCamera(tf2::transformToEigen(t));
        } catch (const tf2::TransformException& e) {
          throw InputError("view '" + camera.frameId() + "' is not tied to the fixed frame '" +
                           fixed_frame_ + "' by /tf_static in the bag: " + e.what());
        }
      }
      p.images[v] = info[v]->rectify(image);
      p.cameras[v] = camera;
      ++p.filled;
    } catch (const InputError& e) {
      p.problem = e.what();
    }
    if (!p.problem.empty()) {
      skipped(p.index, stamp, p.problem);
      pending.erase(it);
    } else if (p.filled == views) {
      BagFrame frame;
      frame.index = p.index;
      frame.stamp_s = stamp;
      frame.images = std::move(p.images);
      frame.cameras = std::move(p.cameras);
      pending.erase(it);
      consume(frame);
    }
  };

  for (const rosbag::MessageInstance& m : view) {
    const std::string& topic = m.getTopic();
    for (std::size_t v = 0; v < views; ++v) {
      if (topic == impl_->info_topics[v]) {
        const auto msg = m.instantiate<sensor_msgs::CameraInfo>();
        if (!msg) continue;
        try {
          // The same calibration with every frame: its maps are built once.
          if (!info[v] || !info[v]->sameCalibration(*msg)) info[v].emplace(*msg);
          info_problem[v].clear();
        } catch (const InputError& e) {
          info[v].reset();  // reported with the next image of this view
          info_problem[v] = e.what();
        }
        if (info[v]) {
          for (const auto& image : waiting[v]) handleImage(v, image);
          waiting[v].clear();
        }
      } else if (topic == image_topics_[v]) {
        ImageMessage msg;
        if (impl_->compressed[v]) {
          msg.compressed = m.instantiate<sensor_msgs::CompressedImage>();
        } else {
          msg.raw = m.instantiate<sensor_msgs::Image>();
        }
        if (!msg.raw && !msg.compressed) continue;
        if (!info[v]) {
          waiting[v].push_back(msg);
        } else {
          handleImage(v, msg);
        }
      }
    }
  }
  for (std::size_t v = 0; v < views; ++v) {
    for (const auto& image : waiting[v]) handleImage(v, image);  // reported: no camera_info
  }
  flushOlderThan(std::numeric_limits<double>::infinity());
}

}  // namespace ros_bridge
}  // namespace fluoro_tracker
