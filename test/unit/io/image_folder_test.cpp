// Folders of real frames as labs keep them, and the calibration files beside them.
#include "fluoro_tracker/io/image_folder.h"

#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "../test_support.h"
#include "fluoro_tracker/io/jointtrack_calibration.h"
#include "fluoro_tracker/io/view_calibration.h"

using namespace fluoro_tracker;
using test_support::TempDir;

TEST(ImageFolder, NaturalOrderComparesDigitRunsByValue) {
  EXPECT_TRUE(io::naturalLess("frame_9.tif", "frame_10.tif"));
  EXPECT_FALSE(io::naturalLess("frame_10.tif", "frame_9.tif"));
  EXPECT_TRUE(io::naturalLess("AT_K1_V1_0160.tif", "AT_K1_V1_0170.tif"));
  EXPECT_TRUE(io::naturalLess("a2b3", "a2b10"));
  EXPECT_TRUE(io::naturalLess("img.tif", "img1.tif"));  // a prefix comes first
  // Equal values: fewer leading zeros first, so that distinct names never compare equal.
  EXPECT_TRUE(io::naturalLess("f7.tif", "f007.tif"));
  EXPECT_FALSE(io::naturalLess("f007.tif", "f7.tif"));
  EXPECT_FALSE(io::naturalLess("same.tif", "same.tif"));
}

TEST(ImageFolder, ListsImagesInNaturalOrderAndNothingElse) {
  TempDir dir;
  const cv::Mat grey(4, 6, CV_8UC1, cv::Scalar(90));
  for (const std::string name : {"frame_10.tif", "frame_9.PNG", "frame_100.tiff"}) {
    ASSERT_TRUE(cv::imwrite(dir.file(name), grey)) << name;
  }
  test_support::writeText(dir.file("notes.txt"), "not a frame");
  test_support::writeText(dir.file(".hidden.tif"), "");
  std::filesystem::create_directory(dir.file("sub.tif"));
  const auto files = io::listImageFiles(dir.path());
  ASSERT_EQ(files.size(), 3u);
  EXPECT_EQ(files[0], dir.file("frame_9.PNG"));
  EXPECT_EQ(files[1], dir.file("frame_10.tif"));
  EXPECT_EQ(files[2], dir.file("frame_100.tiff"));
}

TEST(ImageFolder, AFolderWithoutFramesIsAnError) {
  TempDir dir;
  EXPECT_THROW_WITH(io::listImageFiles(dir.file("absent")), "does not exist");
  test_support::writeText(dir.file("readme.txt"), "x");
  EXPECT_THROW_WITH(io::listImageFiles(dir.path()), "holds no images");
}

TEST(ImageFolder, ReadsGreyAtItsBitDepthAndColourAsGrey) {
  TempDir dir;
  cv::Mat grey16(5, 7, CV_16UC1, cv::Scalar(40000));
  ASSERT_TRUE(cv::imwrite(dir.file("a.png"), grey16));
  const cv::Mat a = io::readFluoroImage(dir.file("a.png"));
  EXPECT_EQ(a.type(), CV_16UC1);
  EXPECT_EQ(a.at<std::uint16_t>(2, 3), 40000);
  cv::Mat colour(5, 7, CV_8UC3, cv::Scalar(100, 100, 100));
  ASSERT_TRUE(cv::imwrite(dir.file("b.png"), colour));
  const cv::Mat b = io::readFluoroImage(dir.file("b.png"));
  EXPECT_EQ(b.type(), CV_8UC1);
  EXPECT_EQ(b.at<std::uint8_t>(1, 1), 100);
  // The real Kneel frames: 8-bit grey TIFF.
  const cv::Mat kneel =
      io::readFluoroImage(test_support::sharedData("jointtrack_kneel/AT_K1_V1_0160.tif"));
  EXPECT_EQ(kneel.type(), CV_8UC1);
  EXPECT_EQ(kneel.cols, 1024);
}

TEST(ImageFolder, OtherPixelTypesAndUnreadableFilesNameTheFile) {
  TempDir dir;
  const cv::Mat floats(3, 3, CV_32FC1, cv::Scalar(0.5));
  ASSERT_TRUE(cv::imwrite(dir.file("float.tif"), floats));
  EXPECT_THROW_WITH(io::readFluoroImage(dir.file("float.tif")), "float.tif' has 32-bit float");
  test_support::writeText(dir.file("broken.tif"), "not a tiff");
  EXPECT_THROW_WITH(io::readFluoroImage(dir.file("broken.tif")), "cannot read image");
}

TEST(ViewCalibration, ReadsJointTrackAndMayaCamFilesByTheirContent) {
  const auto jointtrack = io::loadViewCalibration(
      test_support::sharedData("jointtrack_kneel/calibration.txt"), 1024, 1024, "fluoro_optical");
  EXPECT_EQ(jointtrack.format, io::CalibrationFormat::kJointTrack);
  EXPECT_FALSE(jointtrack.has_extrinsics);
  EXPECT_NEAR(jointtrack.camera.fx(), 1198.0 / 0.373, 1e-9);
  EXPECT_EQ(jointtrack.camera.frameId(), "fluoro_optical");
  const auto mayacam = io::loadViewCalibration(
      test_support::sharedData("autoscoper_sample/Calibration/xr_calib_wrist_cam01.txt"), 1760,
      1760, "fluoro1_optical");
  EXPECT_EQ(mayacam.format, io::CalibrationFormat::kMayaCam);
  EXPECT_TRUE(mayacam.has_extrinsics);
  EXPECT_GT(mayacam.camera.worldFromCamera().translation().norm(), 0.1);
}

TEST(ViewCalibration, BadFilesNameTheProblem) {
  TempDir dir;
  test_support::writeText(dir.file("other.txt"), "CALIBRATION v3\n1 2 3\n");
  EXPECT_THROW_WITH(io::loadViewCalibration(dir.file("other.txt"), 100, 100, "f"),
                    "neither JointTrack's (first line 'CALIBRATION v3'");
  EXPECT_THROW_WITH(io::loadViewCalibration(dir.file("absent.txt"), 100, 100, "f"),
                    "cannot be opened");
  EXPECT_THROW_WITH(
      io::loadViewCalibration(
          test_support::sharedData("autoscoper_sample/Calibration/xr_calib_wrist_cam01.txt"), 1024,
          1024, "f"),
      "is for 1760x1760 images, the frames are 1024x1024");
  test_support::writeText(dir.file("jt.txt"), "JT_INTCALIB\n1198\n0\n");
  EXPECT_THROW_WITH(io::loadViewCalibration(dir.file("jt.txt"), 100, 100, "f"),
                    "expected 4 intrinsic values");
}
