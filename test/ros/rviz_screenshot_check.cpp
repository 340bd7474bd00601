// Checks what rviz shows (started by rviz_demo.test under an X server, e.g. xvfb-run, with
// config/tracker.rviz and a simulated trial playing into tracker_node): once the node has
// tracked frames, a screenshot of the display is taken with scrot and must show both bone
// meshes in their marker colours and the overlay's X-ray frame.
#include <cstdlib>
#include <mutex>

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/TrackingStatus.h"

namespace {

// Pixels whose BGR colour lies in [low, high] (both inclusive).
int countInRange(const cv::Mat& image, const cv::Scalar& low, const cv::Scalar& high) {
  cv::Mat mask;
  cv::inRange(image, low, high, mask);
  return cv::countNonZero(mask);
}

}  // namespace

TEST(Rviz, ShowsTheTrackedBonesAndTheOverlay) {
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  std::string screenshot;
  ASSERT_TRUE(private_nh.getParam("screenshot", screenshot)) << "~screenshot (a PNG path) is unset";
  ASSERT_NE(std::getenv("DISPLAY"), nullptr) << "no X display: run under xvfb-run";

  std::mutex mutex;
  std::size_t statuses = 0;
  auto subscriber = nh.subscribe<fluoro_tracker::TrackingStatus>(
      "/tracker_node/status", 100, [&](const fluoro_tracker::TrackingStatus::ConstPtr&) {
        std::lock_guard<std::mutex> lock(mutex);
        ++statuses;
      });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  // Mid-trial, so that the knee is flexed; the launch delays the bag until rviz is up.
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(90.0);
  while (ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (statuses >= 40) break;
    }
    ros::WallDuration(0.05).sleep();
  }
  ASSERT_GE(statuses, 40u) << "the node tracked too few frames for rviz to show";
  ros::WallDuration(1.0).sleep();  // rviz draws the latest markers and overlay

  const std::string command = "scrot --overwrite '" + screenshot + "'";
  ASSERT_EQ(std::system(command.c_str()), 0) << "'" << command << "' failed";
  const cv::Mat image = cv::imread(screenshot, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty()) << "cannot read the screenshot " << screenshot;
  std::cout << "rviz_screenshot_check: " << image.cols << "x" << image.rows << " screenshot in "
            << screenshot << "\n";

  // The femur's marker is green (0.2, 0.9, 0.2) and the tibia's orange (1.0, 0.6, 0.1), both
  // shaded by rviz's light: count clearly green and clearly orange pixels (BGR).
  const int green = countInRange(image, cv::Scalar(0, 90, 0), cv::Scalar(90, 255, 90));
  const int orange = countInRange(image, cv::Scalar(0, 70, 140), cv::Scalar(80, 170, 255));
  // The overlay shows the X-ray frame: many pixels where blue, green and red are equal and
  // neither black nor white (the background and panels are not grey-level gradients).
  cv::Mat channels[3];
  cv::split(image, channels);
  cv::Mat grey_mask = (channels[0] == channels[1]) & (channels[1] == channels[2]) &
                      (channels[0] > 40) & (channels[0] < 215);
  cv::Mat grey_values;
  channels[0].copyTo(grey_values, grey_mask);
  cv::Mat histogram;
  const int bins = 256;
  const float range[] = {0.0f, 256.0f};
  const float* ranges[] = {range};
  cv::calcHist(&grey_values, 1, nullptr, grey_mask, histogram, 1, &bins, ranges);
  const int grey_levels = cv::countNonZero(histogram > 20);
  std::cout << "rviz_screenshot_check: femur (green) " << green << " px, tibia (orange) " << orange
            << " px, " << grey_levels << " grey levels\n";
  EXPECT_GE(green, 2000) << "the femur's mesh marker is not shown";
  EXPECT_GE(orange, 1000) << "the tibia's mesh marker is not shown";
  EXPECT_GE(grey_levels, 40) << "the overlay's X-ray frame is not shown";
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "rviz_screenshot_check");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
