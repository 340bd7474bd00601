// Folders of real frames as labs keep them.
#include "fluoro_tracker/io/image_folder.h"

#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "../test_support.h"

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
