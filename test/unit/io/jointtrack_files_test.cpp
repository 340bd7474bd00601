// JointTrack calibration and pose files, including the real Kneel study in ../shared/data.
#include <opencv2/imgcodecs.hpp>

#include "../test_support.h"
#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/io/jointtrack_calibration.h"
#include "fluoro_tracker/io/jts_file.h"

using namespace fluoro_tracker;
using test_support::TempDir;

TEST(JointTrackCalibration, ReadsTheRealIntrinsicCalibration) {
  const auto c =
      io::readJointTrackCalibration(test_support::sharedData("jointtrack_kneel/calibration.txt"));
  EXPECT_DOUBLE_EQ(c.principal_distance_mm, 1198.0);
  EXPECT_DOUBLE_EQ(c.x_offset_mm, 0.0);
  EXPECT_DOUBLE_EQ(c.y_offset_mm, 0.0);
  EXPECT_DOUBLE_EQ(c.pixel_size_mm, 0.373);
  EXPECT_FALSE(c.extrinsics.has_value());
  const auto camera = io::cameraFromJointTrack(c, 1024, 1024);
  EXPECT_NEAR(camera.fx(), 1198.0 / 0.373, 1e-9);
  EXPECT_NEAR(camera.cx(), 512.0, 1e-12);
  EXPECT_NEAR(camera.cy(), 511.0, 1e-12);
}

TEST(JointTrackCalibration, OffsetsMoveThePrincipalPoint) {
  const auto c = io::readJointTrackCalibration(
      test_support::sharedData("jointtrack_kneel/calibration wonky-testing.txt"));
  EXPECT_DOUBLE_EQ(c.x_offset_mm, 60.0);
  const auto camera = io::cameraFromJointTrack(c, 1024, 1024);
  EXPECT_NEAR(camera.cx(), 512.0 - 60.0 / 0.373, 1e-9);
  EXPECT_NEAR(camera.cy(), 511.0 + 60.0 / 0.373, 1e-9);
}

TEST(JointTrackCalibration, IntrinsicAndExtrinsicRoundTrip) {
  TempDir dir;
  io::JointTrackCalibration c;
  c.principal_distance_mm = 1000.0;
  c.x_offset_mm = 1.5;
  c.y_offset_mm = -2.0;
  c.pixel_size_mm = 0.25;
  io::JointTrackExtrinsics e;
  e.source_position_mm = Eigen::Vector3d(1000.0, 0.0, 500.0);
  e.image_normal = Eigen::Vector3d(1.0, 0.0, 0.0);  // image to source along +x
  e.image_up = Eigen::Vector3d(0.0, 0.0, 1.0);
  c.extrinsics = e;
  io::writeJointTrackCalibration(dir.file("cal.txt"), c);
  const auto r = io::readJointTrackCalibration(dir.file("cal.txt"));
  EXPECT_DOUBLE_EQ(r.principal_distance_mm, 1000.0);
  EXPECT_DOUBLE_EQ(r.x_offset_mm, 1.5);
  EXPECT_DOUBLE_EQ(r.y_offset_mm, -2.0);
  EXPECT_DOUBLE_EQ(r.pixel_size_mm, 0.25);
  ASSERT_TRUE(r.extrinsics.has_value());
  EXPECT_TRUE(r.extrinsics->source_position_mm.isApprox(e.source_position_mm));

  // The source sits at (1, 0, 0.5) m looking along -x with lab z up: the lab origin lies 1 m
  // in front of it and 0.5 m below the axis, i.e. at positive optical y (rows grow down).
  const auto camera = io::cameraFromJointTrack(r, 512, 512);
  const Eigen::Vector3d origin_in_camera =
      camera.worldFromCamera().inverse() * Eigen::Vector3d::Zero();
  EXPECT_TRUE(origin_in_camera.isApprox(Eigen::Vector3d(0.0, 0.5, 1.0), 1e-12));

  io::JointTrackCalibration intrinsic_only = c;
  intrinsic_only.extrinsics.reset();
  io::writeJointTrackCalibration(dir.file("int.txt"), intrinsic_only);
  EXPECT_FALSE(io::readJointTrackCalibration(dir.file("int.txt")).extrinsics.has_value());
}

TEST(JointTrackCalibration, BadFilesNameTheProblem) {
  TempDir dir;
  EXPECT_THROW_WITH(io::readJointTrackCalibration(dir.file("none.txt")), "cannot be opened");
  test_support::writeText(dir.file("empty.txt"), "\n\n");
  EXPECT_THROW_WITH(io::readJointTrackCalibration(dir.file("empty.txt")), "is empty");
  test_support::writeText(dir.file("header.txt"), "SOMETHING\n1\n2\n3\n4\n");
  EXPECT_THROW_WITH(io::readJointTrackCalibration(dir.file("header.txt")), "JT_INTCALIB");
  test_support::writeText(dir.file("short.txt"), "JT_INTCALIB\n1198\n0\n");
  EXPECT_THROW_WITH(io::readJointTrackCalibration(dir.file("short.txt")), "expected 4");
  test_support::writeText(dir.file("text.txt"), "JT_INTCALIB\n1198\n0\nzero\n0.373\n");
  EXPECT_THROW_WITH(io::readJointTrackCalibration(dir.file("text.txt")), "y offset");
  test_support::writeText(dir.file("ext.txt"),
                          "JT_CALIB_INT_EXT\n1198\n0\n0\n0.373\n\n0,0,0\n1,0,0\n");
  EXPECT_THROW_WITH(io::readJointTrackCalibration(dir.file("ext.txt")), "image up vector");
}

TEST(JtsFile, ReadsTheRealReferencePoses) {
  const auto poses = io::readJtsFile(test_support::sharedData("jointtrack_kneel/fem.jts"));
  ASSERT_EQ(poses.size(), 3u);
  ASSERT_TRUE(poses[0].has_value());
  EXPECT_TRUE(poses[0]->translation().isApprox(Eigen::Vector3d(18.52191, 19.69514, -1027.713)));
  const auto angles = geometry::eulerZXYFromRotation(poses[0]->linear());
  EXPECT_NEAR(geometry::radToDeg(angles.z), -26.69708, 1e-9);
  EXPECT_NEAR(geometry::radToDeg(angles.x), -7.419319, 1e-9);
  EXPECT_NEAR(geometry::radToDeg(angles.y), -0.2587041, 1e-9);
  // The lab's shape-library files use tabs between columns.
  const auto fft = io::readJtsFile(test_support::sharedData("jointtrack_kneel/FFT/tib_fft.jts"));
  ASSERT_EQ(fft.size(), 3u);
  EXPECT_NEAR(fft[2]->translation().z(), -1017.700, 1e-9);
}

TEST(JtsFile, RoundTripWithMissingFrames) {
  TempDir dir;
  io::JtsPoses poses;
  poses.push_back(geometry::makePose(geometry::rotationFromEulerZXY({0.3, -0.1, 0.2}),
                                     Eigen::Vector3d(12.5, -3.25, -1020.0)));
  poses.push_back(std::nullopt);
  poses.push_back(geometry::makePose(geometry::rotationFromEulerZXY({-1.0, 0.4, 2.0}),
                                     Eigen::Vector3d(1.0, 2.0, -990.0)));
  io::writeJtsFile(dir.file("poses.jts"), poses);
  const auto read = io::readJtsFile(dir.file("poses.jts"));
  ASSERT_EQ(read.size(), 3u);
  EXPECT_FALSE(read[1].has_value());
  for (int i : {0, 2}) {
    ASSERT_TRUE(read[i].has_value());
    EXPECT_TRUE(read[i]->matrix().isApprox(poses[i]->matrix(), 1e-7));
  }
}

TEST(JtsFile, BadFilesNameTheProblem) {
  TempDir dir;
  test_support::writeText(dir.file("a.jts"), "JT_EULER_123\nx_tran\n");
  EXPECT_THROW_WITH(io::readJtsFile(dir.file("a.jts")), "JT_EULER_312");
  test_support::writeText(dir.file("b.jts"), "JT_EULER_312\n x_tran, y_tran\n1,2,3,4,5\n");
  EXPECT_THROW_WITH(io::readJtsFile(dir.file("b.jts")), "line 3");
}

TEST(JtsFile, OpticalConversionRoundTrip) {
  const geometry::Pose jt = geometry::makePose(geometry::rotationFromEulerZXY({0.2, 0.1, -0.3}),
                                               Eigen::Vector3d(20.0, 15.0, -1030.0));
  const geometry::Pose optical = io::opticalFromJointTrack(jt);
  EXPECT_TRUE(optical.translation().isApprox(Eigen::Vector3d(0.020, -0.015, 1.030)));
  EXPECT_TRUE(io::jointTrackFromOptical(optical).matrix().isApprox(jt.matrix(), 1e-12));
}

// The whole JointTrack chain on real data: calibration + .jts poses + STL models, converted to
// the optical frame, must project the implants onto their hand-made silhouette labels.
TEST(JointTrackChain, RealReferencePosesProjectOntoTheLabelledSilhouettes) {
  const auto calibration =
      io::readJointTrackCalibration(test_support::sharedData("jointtrack_kneel/calibration.txt"));
  const auto camera = io::cameraFromJointTrack(calibration, 1024, 1024);
  const std::vector<std::string> frames = {"0160", "0170", "0180"};
  for (const std::string bone : {"fem", "tib"}) {
    const auto mesh = geometry::Mesh::load(test_support::sharedData(
        "jointtrack_kneel/" +
        std::string(bone == "fem" ? "KR_right_7_fem.stl" : "KR_right_6_tib.stl")));
    const auto poses =
        io::readJtsFile(test_support::sharedData("jointtrack_kneel/" + bone + ".jts"));
    ASSERT_EQ(poses.size(), frames.size());
    for (std::size_t f = 0; f < frames.size(); ++f) {
      const cv::Mat label =
          cv::imread(test_support::sharedData("jointtrack_kneel/Labels/" + bone + "/AT_K1_V1_" +
                                              frames[f] + "_label_" + bone + ".tif"),
                     cv::IMREAD_GRAYSCALE);
      ASSERT_FALSE(label.empty());
      const geometry::Pose pose = io::opticalFromJointTrack(*poses[f]);
      int inside = 0;
      for (const auto& v : mesh.vertices()) {
        Eigen::Vector2d px;
        ASSERT_TRUE(camera.project(pose * v, &px));
        const int u = static_cast<int>(std::lround(px.x()));
        const int r = static_cast<int>(std::lround(px.y()));
        if (u >= 0 && r >= 0 && u < label.cols && r < label.rows &&
            label.at<std::uint8_t>(r, u) > 0) {
          ++inside;
        }
      }
      const double fraction = static_cast<double>(inside) / mesh.vertexCount();
      EXPECT_GT(fraction, 0.9) << bone << " frame " << frames[f];
    }
  }
}
