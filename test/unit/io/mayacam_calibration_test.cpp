#include "fluoro_tracker/io/mayacam_calibration.h"

#include "../test_support.h"

using namespace fluoro_tracker;
using test_support::TempDir;

TEST(MayaCam, ReadsTheRealAutoscoperCalibration) {
  const auto c = io::readMayaCamCalibration(
      test_support::sharedData("autoscoper_sample/Calibration/xr_calib_left_knee_cam01.txt"));
  EXPECT_EQ(c.image_width, 1760);
  EXPECT_EQ(c.image_height, 1760);
  EXPECT_DOUBLE_EQ(c.camera_matrix(0, 0), 8673.95205439);
  EXPECT_DOUBLE_EQ(c.camera_matrix(1, 2), 866.791017756);
  EXPECT_DOUBLE_EQ(c.rotation(0, 2), 0.999289106453);
  EXPECT_DOUBLE_EQ(c.translation_mm.z(), 1368.54674372);
  const auto camera = io::cameraFromMayaCam(c, "fluoro1_optical");
  EXPECT_DOUBLE_EQ(camera.fx(), 8673.95205439);
  EXPECT_DOUBLE_EQ(camera.fy(), 8724.06439459);
  // The lab origin maps to R*0 + t: 1.37 m in front of the source, and projects near the centre.
  const Eigen::Vector3d origin = camera.worldFromCamera().inverse() * Eigen::Vector3d::Zero();
  EXPECT_TRUE(origin.isApprox(1e-3 * c.translation_mm, 1e-12));
  Eigen::Vector2d px;
  ASSERT_TRUE(camera.project(origin, &px));
  EXPECT_TRUE(camera.contains(px));
}

TEST(MayaCam, EveryRealCalibrationLoads) {
  for (const std::string name : {"left_knee_cam02", "right_ankle_cam01", "right_ankle_cam02",
                                 "wrist_cam01", "wrist_cam02"}) {
    const auto c = io::readMayaCamCalibration(
        test_support::sharedData("autoscoper_sample/Calibration/xr_calib_" + name + ".txt"));
    EXPECT_GT(c.camera_matrix(0, 0), 0.0) << name;
  }
}

TEST(MayaCam, RoundTrip) {
  TempDir dir;
  io::MayaCamCalibration c;
  c.image_height = 1024;
  c.image_width = 768;
  c.camera_matrix << 3000, 0, 380, 0, 3010, 515, 0, 0, 1;
  c.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  c.translation_mm = Eigen::Vector3d(-60.5, 120.25, 1400.0);
  io::writeMayaCamCalibration(dir.file("cam.txt"), c);
  const auto r = io::readMayaCamCalibration(dir.file("cam.txt"));
  EXPECT_EQ(r.image_height, 1024);
  EXPECT_EQ(r.image_width, 768);
  EXPECT_TRUE(r.camera_matrix.isApprox(c.camera_matrix, 1e-12));
  EXPECT_TRUE(r.rotation.isApprox(c.rotation, 1e-11));
  EXPECT_TRUE(r.translation_mm.isApprox(c.translation_mm, 1e-12));
}

TEST(MayaCam, BadFilesNameTheProblem) {
  TempDir dir;
  test_support::writeText(dir.file("a.txt"),
                          "image size\n100,100\n\ncamera matrix\n1,0,0\n0,1,0\n0,0,1\n");
  EXPECT_THROW_WITH(io::readMayaCamCalibration(dir.file("a.txt")), "missing block 'rotation'");
  test_support::writeText(dir.file("b.txt"),
                          "image size\n100,100\n\ncamera matrix\n1,0,0\n0,1,0\n0,0,1\n\nrotation\n"
                          "2,0,0\n0,1,0\n0,0,1\n\ntranslation\n0\n0\n1\n");
  EXPECT_THROW_WITH(io::readMayaCamCalibration(dir.file("b.txt")), "not a proper rotation");
  test_support::writeText(dir.file("c.txt"),
                          "image size\n100,100\n\ncamera matrix\n0,0,0\n0,1,0\n0,0,1\n\nrotation\n"
                          "1,0,0\n0,1,0\n0,0,1\n\ntranslation\n0\n0\n1\n");
  EXPECT_THROW_WITH(io::cameraFromMayaCam(io::readMayaCamCalibration(dir.file("c.txt")), "cam"),
                    "K[0]");
}
