#include "fluoro_tracker/io/poses_csv.h"

#include <fstream>

#include "../test_support.h"

using namespace fluoro_tracker;
using test_support::TempDir;

TEST(PosesCsv, RoundTripKeepsEveryField) {
  TempDir dir;
  std::vector<io::PoseRecord> records;
  records.push_back(
      {0, 100.0, "femur",
       geometry::makePose(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())),
                          Eigen::Vector3d(0.01, -0.02, 0.95)),
       "ok", std::nullopt});
  records.push_back(
      {1, 100.033333333, "tibia", geometry::Pose::Identity(), "suspect", std::nullopt});
  io::writePosesCsv(dir.file("p.csv"), records);

  std::ifstream in(dir.file("p.csv"));
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "frame,stamp,bone,x_m,y_m,z_m,qx,qy,qz,qw,status");

  const auto read = io::readPosesCsv(dir.file("p.csv"));
  ASSERT_EQ(read.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(read[i].frame, records[i].frame);
    EXPECT_NEAR(read[i].stamp, records[i].stamp, 1e-9);
    EXPECT_EQ(read[i].bone, records[i].bone);
    EXPECT_EQ(read[i].status, records[i].status);
    EXPECT_TRUE(read[i].pose.matrix().isApprox(records[i].pose.matrix(), 1e-8));
  }
}

// The quality columns follow `status`; the spread (stop 53) and the inlier fraction at the edge
// offset (stop 55) came last so that readers of the earlier ones by position still find them.
TEST(PosesCsv, QualityColumnsFollowTheStatusWithTheNewestLast) {
  TempDir dir;
  registration::BoneQuality quality;
  quality.contour_inlier_fraction = 0.95;
  quality.contour_rms_px = 0.9;
  quality.contour_spread_px = 0.3;
  quality.offset_inlier_fraction = 0.97;
  quality.contour_points = 800;
  quality.unseen_points = 200;
  quality.out_of_plane_sd_m = 0.0012;
  io::writePosesCsv(dir.file("q.csv"),
                    {{0, 1.0, "tibia", geometry::Pose::Identity(), "ok", quality}});
  std::ifstream in(dir.file("q.csv"));
  std::string header;
  std::string row;
  std::getline(in, header);
  std::getline(in, row);
  EXPECT_EQ(header, std::string(io::kPosesCsvHeader) +
                        ",contour_inlier_fraction,contour_rms_px,out_of_plane_sd_mm,"
                        "contour_spread_px,offset_inlier_fraction,unseen_fraction");
  EXPECT_NE(row.find(",ok,0.9500,0.9000,1.2000,0.3000,0.9700,0.2500"), std::string::npos) << row;
  EXPECT_EQ(io::readPosesCsv(dir.file("q.csv")).size(), 1u);
}

TEST(PosesCsv, ExtraColumnsAreAllowed) {
  TempDir dir;
  test_support::writeText(dir.file("p.csv"),
                          "frame,stamp,bone,x_m,y_m,z_m,qx,qy,qz,qw,status,cost\n"
                          "3,1.5,femur,0,0,1,0,0,0,1,lost,12.5\n");
  const auto read = io::readPosesCsv(dir.file("p.csv"));
  ASSERT_EQ(read.size(), 1u);
  EXPECT_EQ(read[0].frame, 3);
  EXPECT_EQ(read[0].status, "lost");
}

TEST(PosesCsv, BadInputNamesTheProblem) {
  TempDir dir;
  test_support::writeText(dir.file("h.csv"), "frame,time,bone\n");
  EXPECT_THROW_WITH(io::readPosesCsv(dir.file("h.csv")), "header");
  test_support::writeText(dir.file("n.csv"),
                          std::string(io::kPosesCsvHeader) + "\n0,0,femur,nan,0,1,0,0,0,1,ok\n");
  EXPECT_THROW_WITH(io::readPosesCsv(dir.file("n.csv")), "line 2 column 4");
  test_support::writeText(dir.file("q.csv"),
                          std::string(io::kPosesCsvHeader) + "\n0,0,femur,0,0,1,0,0,0,2,ok\n");
  EXPECT_THROW_WITH(io::readPosesCsv(dir.file("q.csv")), "unit length");
  test_support::writeText(dir.file("s.csv"),
                          std::string(io::kPosesCsvHeader) + "\n0,0,femur,0,0,1,0,0,0,1,great\n");
  EXPECT_THROW_WITH(io::readPosesCsv(dir.file("s.csv")), "status 'great'");
  geometry::Pose nan_pose = geometry::Pose::Identity();
  nan_pose.translation().x() = std::nan("");
  EXPECT_THROW_WITH(
      io::writePosesCsv(dir.file("w.csv"), {{0, 0.0, "femur", nan_pose, "ok", std::nullopt}}),
      "non-finite pose");
}
