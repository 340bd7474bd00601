#include "fluoro_tracker/ros/trial_bag_writer.h"

#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "../test_support.h"
#include "fluoro_tracker/ros/bag_frame_reader.h"
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

void writeTrial(const sim::TrialSimulator& simulator, const std::string& path,
                std::optional<ros_bridge::TrialBagWriter::Compression> compression = std::nullopt) {
  ros_bridge::TrialBagWriter writer(path, simulator.views(), simulator.fixedFrame(),
                                    simulator.settings().start_stamp_s, compression);
  std::mt19937_64 rng(1);
  for (int i = 0; i < simulator.frameCount(); ++i) writer.write(simulator.render(i, &rng));
}

// Every frame of a bag as track_bag reads it (a skipped frame fails the test).
std::vector<ros_bridge::BagFrame> readFrames(const std::string& path) {
  ros_bridge::BagFrameReader reader(path, {}, "");
  std::vector<ros_bridge::BagFrame> frames;
  reader.read([&](const ros_bridge::BagFrame& f) { frames.push_back(f); },
              [](int index, double, const std::string& reason) {
                ADD_FAILURE() << "frame " << index << " skipped: " << reason;
              });
  return frames;
}

double maxAbsDifference(const cv::Mat& a, const cv::Mat& b) {
  return cv::norm(a, b, cv::NORM_INF);
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

// Bags recorded through image_transport's compressed transport hold
// sensor_msgs/CompressedImage on .../image_raw/compressed; PNG is lossless at 8 and 16 bits.
TEST(TrialBagWriter, PngCompressedFramesReadBackExactlyAsTheRawOnes) {
  TempDir dir;
  for (const int bits : {8, 16}) {
    sim::TrialSimulatorSettings settings = tinyTrial(bits == 8 ? 1 : 2);
    settings.detector.bit_depth = bits;
    const sim::TrialSimulator simulator(settings);
    const std::string raw = dir.file("raw" + std::to_string(bits) + ".bag");
    const std::string png = dir.file("png" + std::to_string(bits) + ".bag");
    writeTrial(simulator, raw);
    writeTrial(simulator, png, ros_bridge::TrialBagWriter::Compression{});

    {
      rosbag::Bag bag(png, rosbag::bagmode::Read);
      const std::string view = bits == 8 ? "fluoro" : "fluoro1";
      EXPECT_EQ(rosbag::View(bag, rosbag::TopicQuery("/" + view + "/image_raw")).size(), 0u);
      rosbag::View images(bag, rosbag::TopicQuery("/" + view + "/image_raw/compressed"));
      ASSERT_EQ(images.size(), 3u);
      const auto first = images.begin()->instantiate<sensor_msgs::CompressedImage>();
      ASSERT_TRUE(first);
      const std::string encoding = bits == 8 ? "mono8" : "mono16";
      EXPECT_EQ(first->format, encoding + "; png compressed " + encoding);
    }
    const auto expected = readFrames(raw);
    const auto frames = readFrames(png);
    ASSERT_EQ(frames.size(), 3u);
    ASSERT_EQ(expected.size(), 3u);
    for (std::size_t f = 0; f < frames.size(); ++f) {
      EXPECT_EQ(frames[f].stamp_s, expected[f].stamp_s);
      ASSERT_EQ(frames[f].images.size(), expected[f].images.size());
      for (std::size_t v = 0; v < frames[f].images.size(); ++v) {
        EXPECT_EQ(frames[f].images[v].type(), bits == 8 ? CV_8UC1 : CV_16UC1);
        EXPECT_EQ(maxAbsDifference(frames[f].images[v], expected[f].images[v]), 0.0)
            << bits << "-bit frame " << f << " view " << v;
        EXPECT_TRUE(frames[f].cameras[v].worldFromCamera().isApprox(
            expected[f].cameras[v].worldFromCamera(), 1e-12));
      }
    }
  }
}

TEST(TrialBagWriter, JpegFramesAreCloseAndSixteenBitOnesAreRefused) {
  TempDir dir;
  const sim::TrialSimulator simulator(tinyTrial(1));
  writeTrial(simulator, dir.file("raw.bag"));
  writeTrial(simulator, dir.file("jpeg.bag"),
             ros_bridge::TrialBagWriter::Compression{ros_bridge::ImageCompression::kJpeg, 95});
  const auto expected = readFrames(dir.file("raw.bag"));
  const auto frames = readFrames(dir.file("jpeg.bag"));
  ASSERT_EQ(frames.size(), expected.size());
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const double largest = maxAbsDifference(frames[f].images[0], expected[f].images[0]);
    EXPECT_GT(largest, 0.0) << "JPEG is lossy";
    EXPECT_LT(largest, 32.0) << "frame " << f;
    EXPECT_LT(cv::norm(frames[f].images[0], expected[f].images[0], cv::NORM_L1) /
                  static_cast<double>(expected[f].images[0].total()),
              2.0);
  }
  EXPECT_THROW_WITH(
      ros_bridge::toCompressedImageMessage(cv::Mat(4, 4, CV_16UC1, cv::Scalar(9)),
                                           std_msgs::Header(), ros_bridge::ImageCompression::kJpeg),
      "as PNG");
  EXPECT_THROW_WITH(ros_bridge::parseImageCompression("zip", "--compression"),
                    "--compression 'zip'");
}

TEST(RosConversions, CompressedImagesThatAreNoFluoroscopyFrameNameTheProblem) {
  sensor_msgs::CompressedImage message;
  message.header.frame_id = "fluoro_optical";
  message.format = "mono8; png compressed mono8";
  EXPECT_THROW_WITH(ros_bridge::fromCompressedImageMessage(message), "has no data");
  message.data = {1, 2, 3, 4, 5, 6, 7, 8};
  EXPECT_THROW_WITH(ros_bridge::fromCompressedImageMessage(message),
                    "format 'mono8; png compressed mono8') could not be decoded");
  message.format = "16UC1; compressedDepth png";
  EXPECT_THROW_WITH(ros_bridge::fromCompressedImageMessage(message), "compressedDepth");
  // Colour (as a bgr8 stream would be compressed) comes back grey.
  cv::Mat colour(3, 5, CV_8UC3, cv::Scalar(40, 80, 120));
  message.format = "bgr8; png compressed bgr8";
  ASSERT_TRUE(cv::imencode(".png", colour, message.data));
  const cv::Mat grey = ros_bridge::fromCompressedImageMessage(message);
  ASSERT_EQ(grey.type(), CV_8UC1);
  cv::Mat expected;
  cv::cvtColor(colour, expected, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::norm(grey, expected, cv::NORM_INF), 0.0);
}
