// The calibration files beside a lab's frames: JointTrack's and MayaCam's, told apart by content.
#include "fluoro_tracker/io/view_calibration.h"

#include "../test_support.h"

using namespace fluoro_tracker;
using test_support::TempDir;

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
