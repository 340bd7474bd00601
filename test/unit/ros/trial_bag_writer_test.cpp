#include "fluoro_tracker/ros/trial_bag_writer.h"

#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>

#include "../test_support.h"
#include "fluoro_tracker/ros/conversions.h"

using namespace fluoro_tracker;
using test_support::TempDir;

namespace {

sim::TrialSimulatorSettings tinyTrial(int views) {
  sim::TrialSimulatorSettings s;
  s.image_width = 256;
  s.image_height = 256;
  s.pixel_spacing_mm = 1.52;
  s.views = views;
  s.motion.frames = 3;
  return s;
}

void writeTrial(const sim::TrialSimulator& simulator, const std::string& path) {
  ros_bridge::TrialBagWriter writer(path, simulator.views(), simulator.fixedFrame(),
                                    simulator.settings().start_stamp_s);
  std::mt19937_64 rng(1);
  for (int i = 0; i < simulator.frameCount(); ++i) writer.write(simulator.render(i, &rng));
}

}  // namespace

TEST(TrialBagWriter, SingleViewBagFollowsTheContract) {
  TempDir dir;
  const sim::TrialSimulator simulator(tinyTrial(1));
  writeTrial(simulator, dir.file("t.bag"));

  rosbag::Bag bag(dir.file("t.bag"), rosbag::bagmode::Read);
  rosbag::View images(bag, rosbag::TopicQuery("/fluoro/image_raw"));
  rosbag::View infos(bag, rosbag::TopicQuery("/fluoro/camera_info"));
  EXPECT_EQ(images.size(), 3u);
  EXPECT_EQ(infos.size(), 3u);
  EXPECT_EQ(rosbag::View(bag, rosbag::TopicQuery("/tf_static")).size(), 0u);
  int i = 0;
  for (const rosbag::MessageInstance& m : images) {
    const auto image = m.instantiate<sensor_msgs::Image>();
    ASSERT_TRUE(image);
    EXPECT_EQ(image->encoding, "mono8");
    EXPECT_EQ(image->header.frame_id, "fluoro_optical");
    EXPECT_NEAR(image->header.stamp.toSec(), simulator.truth(i).stamp_s, 1e-6);
    EXPECT_EQ(m.getTime(), image->header.stamp);
    const cv::Mat pixels = ros_bridge::fromImageMessage(*image);
    EXPECT_EQ(pixels.cols, 256);
    ++i;
  }
  for (const rosbag::MessageInstance& m : infos) {
    const auto info = m.instantiate<sensor_msgs::CameraInfo>();
    ASSERT_TRUE(info);
    const geometry::XrayCamera camera = ros_bridge::fromCameraInfo(*info);
    EXPECT_NEAR(camera.fx(), 1200.0 / 1.52, 1e-9);
    EXPECT_EQ(camera.width(), 256);
  }
}

TEST(TrialBagWriter, BiplaneBagTiesViewsToTheLabWithTfStatic) {
  TempDir dir;
  sim::TrialSimulatorSettings settings = tinyTrial(2);
  settings.detector.bit_depth = 16;
  const sim::TrialSimulator simulator(settings);
  writeTrial(simulator, dir.file("t.bag"));

  rosbag::Bag bag(dir.file("t.bag"), rosbag::bagmode::Read);
  for (const std::string view : {"fluoro1", "fluoro2"}) {
    rosbag::View images(bag, rosbag::TopicQuery("/" + view + "/image_raw"));
    ASSERT_EQ(images.size(), 3u) << view;
    EXPECT_EQ(images.begin()->instantiate<sensor_msgs::Image>()->encoding, "mono16");
  }
  rosbag::View tf(bag, rosbag::TopicQuery("/tf_static"));
  ASSERT_EQ(tf.size(), 1u);
  tf2_msgs::TFMessage::ConstPtr message;
  for (const rosbag::MessageInstance& m : tf) {
    const auto header = m.getConnectionHeader();
    ASSERT_TRUE(header);
    ASSERT_TRUE(header->count("latching"));
    EXPECT_EQ(header->at("latching"), "1");
    message = m.instantiate<tf2_msgs::TFMessage>();
  }
  ASSERT_TRUE(message);
  ASSERT_EQ(message->transforms.size(), 2u);
  EXPECT_EQ(message->transforms[1].header.frame_id, "lab");
  EXPECT_EQ(message->transforms[1].child_frame_id, "fluoro2_optical");
  const auto& q = message->transforms[1].transform.rotation;
  const Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
  EXPECT_TRUE(rotation.toRotationMatrix().isApprox(
      simulator.views()[1].camera.worldFromCamera().linear(), 1e-9));
}

TEST(RosConversions, BadMessagesNameTheProblem) {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = "fluoro_optical";
  info.width = 100;
  info.height = 100;
  EXPECT_THROW_WITH(ros_bridge::fromCameraInfo(info), "uncalibrated");
  sensor_msgs::Image image;
  image.header.frame_id = "fluoro_optical";
  image.encoding = "32FC1";
  image.width = 1;
  image.height = 1;
  image.step = 4;
  image.data.resize(4);
  EXPECT_THROW_WITH(ros_bridge::fromImageMessage(image), "encoding '32FC1'");
  geometry_msgs::Pose pose;
  pose.orientation.w = std::nan("");
  EXPECT_THROW_WITH(ros_bridge::fromPoseMessage(pose), "non-finite");
  EXPECT_THROW_WITH(ros_bridge::toImageMessage(cv::Mat(2, 2, CV_32F), std_msgs::Header()),
                    "8- or 16-bit");
}
