#include "fluoro_tracker/ros/trial_bag_writer.h"

#include <geometry_msgs/TransformStamped.h>
#include <tf2_msgs/TFMessage.h>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/ros/conversions.h"

namespace fluoro_tracker {
namespace ros_bridge {

std::optional<TrialBagWriter::Compression> TrialBagWriter::compressionFromOptions(
    const std::string& text, int jpeg_quality) {
  if (text != "none" && text != "png" && text != "jpeg") {
    throw InputError("--compression '" + text + "' is not none, png or jpeg");
  }
  if (jpeg_quality < 1 || jpeg_quality > 100) {
    throw InputError("--jpeg-quality must be between 1 and 100");
  }
  if (text == "none") return std::nullopt;
  return Compression{parseImageCompression(text, "--compression"), jpeg_quality};
}

TrialBagWriter::TrialBagWriter(const std::string& path, const std::vector<io::FluoroView>& views,
                               const std::string& fixed_frame, double first_stamp_s,
                               std::optional<Compression> compression)
    : views_(views), compression_(compression) {
  try {
    bag_.open(path, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    throw InputError("cannot create bag '" + path + "': " + e.what());
  }
  if (views_.size() > 1) {
    tf2_msgs::TFMessage tf;
    const ros::Time stamp(first_stamp_s);
    for (const auto& view : views_) {
      geometry_msgs::TransformStamped t;
      t.header.stamp = stamp;
      t.header.frame_id = fixed_frame;
      t.child_frame_id = view.camera.frameId();
      t.transform = toTransformMessage(view.camera.worldFromCamera());
      tf.transforms.push_back(t);
    }
    // A custom connection header replaces rosbag's own, so it must carry the type too.
    auto header = boost::make_shared<ros::M_string>();
    (*header)["type"] = ros::message_traits::datatype(tf);
    (*header)["md5sum"] = ros::message_traits::md5sum(tf);
    (*header)["message_definition"] = ros::message_traits::definition(tf);
    (*header)["latching"] = "1";
    (*header)["callerid"] = "/fluoro_tracker_trial_bag_writer";
    bag_.write("/tf_static", stamp, tf, header);
  }
}

TrialBagWriter::~TrialBagWriter() {
  close();
}

void TrialBagWriter::write(int index, double stamp_s, const std::vector<cv::Mat>& images) {
  if (images.size() != views_.size()) {
    throw InputError("frame " + std::to_string(index) + " has " + std::to_string(images.size()) +
                     " image(s) for " + std::to_string(views_.size()) + " view(s)");
  }
  const ros::Time stamp(stamp_s);
  for (std::size_t v = 0; v < views_.size(); ++v) {
    sensor_msgs::CameraInfo info = toCameraInfo(views_[v].camera, stamp, views_[v].distortion);
    info.header.seq = sequence_;
    try {
      if (compression_) {
        bag_.write(imageTopic(views_[v]), stamp,
                   toCompressedImageMessage(images[v], info.header, compression_->format,
                                            compression_->jpeg_quality));
      } else {
        bag_.write(imageTopic(views_[v]), stamp, toImageMessage(images[v], info.header));
      }
    } catch (const InputError& e) {
      throw InputError("frame " + std::to_string(index) + ", view " + views_[v].name + ": " +
                       e.what());
    }
    bag_.write(cameraInfoTopic(views_[v]), stamp, info);
  }
  ++sequence_;
}

void TrialBagWriter::close() {
  if (bag_.isOpen()) bag_.close();
}

}  // namespace ros_bridge
}  // namespace fluoro_tracker
