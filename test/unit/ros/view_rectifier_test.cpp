#include "fluoro_tracker/ros/view_rectifier.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "../test_support.h"
#include "fluoro_tracker/ros/conversions.h"
#include "fluoro_tracker/sim/trial_simulator.h"

using namespace fluoro_tracker;

namespace {

// A simulated frame of a knee on a 512 x 512 detector, noise-free, and its camera_info.
struct PinholeFrame {
  cv::Mat image;
  sensor_msgs::CameraInfo info;
  PinholeFrame() {
    sim::TrialSimulatorSettings s;
    s.image_width = s.image_height = 512;
    s.pixel_spacing_mm = 0.76;
    s.motion.frames = 3;
    s.detector.photons_per_pixel = 0.0;  // no noise: differences are geometry and interpolation
    const sim::TrialSimulator simulator(s);
    std::mt19937_64 rng(3);
    image = simulator.render(1, &rng).images[0];
    info = ros_bridge::toCameraInfo(simulator.views()[0].camera, ros::Time(1.0));
  }
};

double meanAbsoluteDifference(const cv::Mat& a, const cv::Mat& b, const cv::Rect& region) {
  cv::Mat difference;
  cv::absdiff(a(region), b(region), difference);
  return cv::mean(difference)[0];
}

}  // namespace

// An image intensifier's pincushion, put on a pinhole frame and taken off again: the rectified
// frame matches the pinhole one over the field, the distorted one does not.
TEST(ViewRectifier, RemovesTheLensDistortionItsCameraInfoDescribes) {
  const PinholeFrame pinhole;
  sensor_msgs::CameraInfo info = pinhole.info;
  info.distortion_model = "plumb_bob";
  info.D = {6.0, 0.0, 0.0, 0.0, 0.0};  // 6 px at 160 px from the centre
  const cv::Mat distorted = imaging::applyLensDistortion(
      pinhole.image, ros_bridge::fromCameraInfo(info), ros_bridge::lensDistortion(info));
  const ros_bridge::ViewRectifier rectifier(info);
  EXPECT_TRUE(rectifier.removesDistortion());
  const cv::Mat rectified = rectifier.rectify(distorted);
  ASSERT_EQ(rectified.size(), pinhole.image.size());
  ASSERT_EQ(rectified.type(), pinhole.image.type());
  const cv::Rect field(96, 96, 320, 320);  // inside the round collimator
  const double before = meanAbsoluteDifference(distorted, pinhole.image, field);
  const double after = meanAbsoluteDifference(rectified, pinhole.image, field);
  EXPECT_GT(before, 4.0 * after) << "before " << before << ", after " << after;
  EXPECT_LT(after, 1.5);
  // The camera is K's pinhole either way.
  EXPECT_DOUBLE_EQ(rectifier.camera().fx(), pinhole.info.K[0]);
  EXPECT_TRUE(rectifier.sameCalibration(info));
  EXPECT_FALSE(rectifier.sameCalibration(pinhole.info));
}

TEST(ViewRectifier, LeavesAFrameWithoutDistortionAsItIs) {
  const PinholeFrame pinhole;
  const ros_bridge::ViewRectifier rectifier(pinhole.info);  // plumb_bob, all zero
  EXPECT_FALSE(rectifier.removesDistortion());
  const cv::Mat same = rectifier.rectify(pinhole.image);
  EXPECT_EQ(same.data, pinhole.image.data);
  sensor_msgs::CameraInfo no_model = pinhole.info;
  no_model.distortion_model.clear();
  no_model.D.clear();
  EXPECT_FALSE(ros_bridge::ViewRectifier(no_model).removesDistortion());
}

TEST(ViewRectifier, BadDistortionIsNamed) {
  const PinholeFrame pinhole;
  sensor_msgs::CameraInfo info = pinhole.info;
  info.distortion_model = "polynomial_42";
  info.D = {0.1, 0.0, 0.0, 0.0, 0.0};
  EXPECT_THROW_WITH(ros_bridge::ViewRectifier{info}, "distortion model 'polynomial_42'");
  info.distortion_model = "plumb_bob";
  info.D = {0.1, 0.0, 0.0};
  EXPECT_THROW_WITH(ros_bridge::ViewRectifier{info}, "5 distortion coefficients, not 3");
  info.D = {0.1, 0.0, 0.0, 0.0, std::nan("")};
  EXPECT_THROW_WITH(ros_bridge::ViewRectifier{info}, "non-finite distortion coefficient");
  const ros_bridge::ViewRectifier fine(pinhole.info);
  EXPECT_THROW_WITH(fine.rectify(cv::Mat(100, 100, CV_8UC1, cv::Scalar(0))),
                    "is 100x100 but its camera_info says 512x512");
}

TEST(ViewRectifier, CameraInfoCarriesTheViewsDistortion) {
  const geometry::XrayCamera camera(64, 48, 500.0, 500.0, 31.5, 23.5, "fluoro_optical");
  const imaging::LensDistortion lens{"rational_polynomial",
                                     {0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0}};
  const sensor_msgs::CameraInfo info = ros_bridge::toCameraInfo(camera, ros::Time(1.0), lens);
  EXPECT_EQ(info.distortion_model, "rational_polynomial");
  EXPECT_EQ(info.D, lens.coefficients);
  EXPECT_TRUE(ros_bridge::ViewRectifier(info).removesDistortion());
  const sensor_msgs::CameraInfo plain = ros_bridge::toCameraInfo(camera, ros::Time(1.0));
  EXPECT_EQ(plain.distortion_model, "plumb_bob");
  EXPECT_EQ(plain.D, std::vector<double>(5, 0.0));
}
