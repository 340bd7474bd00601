// Runs the real track_bag executable on real bags made by the simulator, and checks its
// output against the ground truth, and its answers to bad input.
#include <cstdlib>
#include <fstream>
#include <map>

#include "../test_support.h"
#include "fluoro_tracker/io/jts_file.h"
#include "fluoro_tracker/io/kinematics_csv.h"
#include "fluoro_tracker/io/poses_csv.h"
#include "fluoro_tracker/io/trial_config.h"
#include "fluoro_tracker/ros/bag_frame_reader.h"
#include "fluoro_tracker/ros/conversions.h"
#include "fluoro_tracker/ros/trial_bag_writer.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace fluoro_tracker;
using test_support::TempDir;

namespace {

struct Trial {
  TempDir dir;
  std::vector<io::PoseRecord> truth;
  explicit Trial(
      int views, int frames = 8,
      std::optional<ros_bridge::TrialBagWriter::Compression> compression = std::nullopt) {
    sim::TrialSimulatorSettings s;
    s.views = views;
    s.motion.frames = frames;
    // A brisk but physiological motion: ~4 deg of flexion per frame at 30 Hz. (Frame-to-frame
    // tracking from the previous solution slips at much faster motion, e.g. 10 deg per frame.)
    s.motion.start_flexion_deg = 5.0;
    s.motion.max_flexion_deg = 20.0;
    const sim::TrialSimulator simulator(s);
    simulator.writeModels(dir.file("models"));
    io::saveTrialConfig(dir.file("trial.yaml"), simulator.trialConfig(dir.file("models")));
    ros_bridge::TrialBagWriter writer(dir.file("trial.bag"), simulator.views(),
                                      simulator.fixedFrame(), s.start_stamp_s, compression);
    std::mt19937_64 rng(1);
    for (int i = 0; i < frames; ++i) {
      const auto frame = simulator.render(i, &rng);
      writer.write(frame);
      truth.push_back({i, frame.stamp_s, "femur", frame.femur, "ok", std::nullopt});
      truth.push_back({i, frame.stamp_s, "tibia", frame.tibia, "ok", std::nullopt});
    }
    writer.close();
    io::writePosesCsv(dir.file("truth.csv"), truth);
  }
};

// Runs track_bag with `args`; returns its exit code and leaves its output in `output`.
int runTrackBag(const std::string& args, std::string* output) {
  return test_support::runCommand(std::string(TRACK_BAG_EXECUTABLE) + " " + args, output);
}

}  // namespace

TEST(TrackBag, TracksASimulatedSinglePlaneTrial) {
  Trial trial(1);
  std::string output;
  ASSERT_EQ(
      runTrackBag("--config " + trial.dir.file("trial.yaml") + " --bag " +
                      trial.dir.file("trial.bag") + " --poses-csv " + trial.dir.file("poses.csv") +
                      " --truth-csv " + trial.dir.file("truth.csv") + " --kinematics-csv " +
                      trial.dir.file("kinematics.csv") + " --contact-csv " +
                      trial.dir.file("contact.csv") + " --jts-dir " + trial.dir.file("jts") +
                      " --out-bag " + trial.dir.file("out.bag"),
                  &output),
      0)
      << output;
  EXPECT_NE(output.find("8 frame(s), 8 tracked, 0 skipped"), std::string::npos) << output;
  // Kinematics: one row per frame for the knee, close to the truth's joint coordinates.
  const auto kinematics = io::readKinematicsCsv(trial.dir.file("kinematics.csv"));
  ASSERT_EQ(kinematics.size(), 8u);
  for (const auto& k : kinematics) {
    EXPECT_EQ(k.joint, "knee");
    const geometry::Pose femur = trial.truth[2 * k.frame].pose;
    const geometry::Pose tibia = trial.truth[2 * k.frame + 1].pose;
    ASSERT_EQ(trial.truth[2 * k.frame].bone, "femur");
    const auto truth = kinematics::kneeCoordinates(femur, tibia, kinematics::Side::kRight);
    EXPECT_NEAR(geometry::radToDeg(k.coordinates.flexion_rad),
                geometry::radToDeg(truth.flexion_rad), 2.0)
        << "frame " << k.frame;
    EXPECT_NEAR(k.coordinates.x_m, truth.x_m, 0.002) << "frame " << k.frame;
  }
  // Contact: a header and one row per frame.
  std::ifstream contact(trial.dir.file("contact.csv"));
  std::string line;
  std::getline(contact, line);
  EXPECT_EQ(line.rfind("frame,stamp,joint,in_collision,max_depth_mm", 0), 0u) << line;
  int contact_rows = 0;
  while (std::getline(contact, line)) contact_rows += line.empty() ? 0 : 1;
  EXPECT_EQ(contact_rows, 8);
  // Output bag: the input's messages plus tf, kinematics and status at every image stamp.
  {
    rosbag::Bag out(trial.dir.file("out.bag"));
    std::map<std::string, int> counts;
    for (const rosbag::MessageInstance& m : rosbag::View(out)) ++counts[m.getTopic()];
    EXPECT_EQ(counts["/fluoro/image_raw"], 8);
    EXPECT_EQ(counts["/tf"], 8);
    EXPECT_EQ(counts["/fluoro_tracker/kinematics"], 8);
    EXPECT_EQ(counts["/fluoro_tracker/status"], 8);
  }
  // JointTrack export: the same poses, in JointTrack's camera frame and millimetres.
  const auto jts = io::readJtsFile(trial.dir.file("jts") + "/tibia.jts");
  ASSERT_EQ(jts.size(), 8u);
  const auto written = io::readPosesCsv(trial.dir.file("poses.csv"));
  ASSERT_TRUE(jts[3].has_value());
  EXPECT_TRUE(io::opticalFromJointTrack(*jts[3]).isApprox(written[2 * 3 + 1].pose, 1e-6));
  const auto poses = io::readPosesCsv(trial.dir.file("poses.csv"));
  ASSERT_EQ(poses.size(), trial.truth.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(poses[i].frame, trial.truth[i].frame);
    EXPECT_EQ(poses[i].bone, trial.truth[i].bone);
    EXPECT_NEAR(poses[i].stamp, trial.truth[i].stamp, 1e-6);
    // Single plane: in-plane (optical x, y) within 1 mm; along the beam the error is larger
    // and not asserted tightly here.
    const Eigen::Vector3d error = poses[i].pose.translation() - trial.truth[i].pose.translation();
    EXPECT_LT(std::abs(error.x()), 0.001) << poses[i].bone << " frame " << poses[i].frame;
    EXPECT_LT(std::abs(error.y()), 0.001) << poses[i].bone << " frame " << poses[i].frame;
    EXPECT_LT(std::abs(error.z()), 0.015) << poses[i].bone << " frame " << poses[i].frame;
    EXPECT_LT(geometry::rotationAngleBetween(poses[i].pose.linear(), trial.truth[i].pose.linear()),
              geometry::degToRad(3.0));
  }
}

TEST(TrackBag, TracksABiplaneTrialInTheLabFrame) {
  Trial trial(2, 4);
  std::string output;
  ASSERT_EQ(
      runTrackBag("--config " + trial.dir.file("trial.yaml") + " --bag " +
                      trial.dir.file("trial.bag") + " --poses-csv " + trial.dir.file("poses.csv"),
                  &output),
      0)
      << output;
  const auto poses = io::readPosesCsv(trial.dir.file("poses.csv"));
  ASSERT_EQ(poses.size(), trial.truth.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    // Checks the bi-plane plumbing (tf_static, lab frame, grouping of views): a wrong view
    // transform puts bones centimetres off or fails. The bound is not the accuracy target:
    // edges found slightly inside the metal silhouette in both views still pull the bones a few
    // millimetres away from both sources (a known limitation of the image term).
    EXPECT_LT((poses[i].pose.translation() - trial.truth[i].pose.translation()).norm(), 0.008)
        << poses[i].bone << " frame " << poses[i].frame;
  }
}

TEST(TrackBag, InitCsvRegistersEachFrameFromItsOwnGuess) {
  Trial trial(1, 4);
  // Guesses: the truth moved 1.5 mm in-plane and turned 2 deg, frame by frame.
  std::vector<io::PoseRecord> guesses = trial.truth;
  for (auto& g : guesses) {
    g.pose.translation() += Eigen::Vector3d(0.0015, -0.001, 0.0);
    g.pose.linear() = g.pose.linear() * geometry::rotationZ(geometry::degToRad(2.0));
  }
  io::writePosesCsv(trial.dir.file("guesses.csv"), guesses);
  std::string output;
  ASSERT_EQ(
      runTrackBag("--config " + trial.dir.file("trial.yaml") + " --bag " +
                      trial.dir.file("trial.bag") + " --poses-csv " + trial.dir.file("poses.csv") +
                      " --init-csv " + trial.dir.file("guesses.csv"),
                  &output),
      0)
      << output;
  const auto poses = io::readPosesCsv(trial.dir.file("poses.csv"));
  ASSERT_EQ(poses.size(), trial.truth.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Vector3d error = poses[i].pose.translation() - trial.truth[i].pose.translation();
    EXPECT_LT(std::hypot(error.x(), error.y()), 0.001)
        << poses[i].bone << " frame " << poses[i].frame;
  }
  // A guess file without frame 3 is an error that names the bone and frame.
  guesses.resize(6);
  io::writePosesCsv(trial.dir.file("short.csv"), guesses);
  EXPECT_NE(runTrackBag("--config " + trial.dir.file("trial.yaml") + " --bag " +
                            trial.dir.file("trial.bag") + " --poses-csv " +
                            trial.dir.file("p2.csv") + " --init-csv " + trial.dir.file("short.csv"),
                        &output),
            0);
  EXPECT_NE(output.find("no pose for bone 'femur' at frame 3"), std::string::npos) << output;
  // The frames that had guesses are still tracked and written.
  const auto partial = io::readPosesCsv(trial.dir.file("p2.csv"));
  ASSERT_EQ(partial.size(), 6u);
  EXPECT_EQ(partial.back().frame, 2);
}

TEST(TrackBag, BadInputGivesAClearErrorAndNonZeroExit) {
  Trial trial(1, 2);
  std::string output;
  const std::string base =
      "--config " + trial.dir.file("trial.yaml") + " --poses-csv " + trial.dir.file("p.csv");
  EXPECT_NE(runTrackBag(base + " --bag " + trial.dir.file("missing.bag"), &output), 0);
  EXPECT_NE(output.find("does not exist"), std::string::npos) << output;
  EXPECT_NE(
      runTrackBag(base + " --bag " + trial.dir.file("trial.bag") + " --image-topic /nope", &output),
      0);
  EXPECT_NE(output.find("no topic '/nope'"), std::string::npos) << output;
  test_support::writeText(trial.dir.file("bad.yaml"), "bones: [");
  EXPECT_NE(runTrackBag("--config " + trial.dir.file("bad.yaml") + " --bag " +
                            trial.dir.file("trial.bag") + " --poses-csv " + trial.dir.file("p.csv"),
                        &output),
            0);
  EXPECT_NE(output.find("not valid YAML"), std::string::npos) << output;
  EXPECT_NE(runTrackBag(base + " --bag " + trial.dir.file("trial.bag") +
                            " --out-bag /nonexistent_dir/out.bag",
                        &output),
            0);
  EXPECT_NE(output.find("/nonexistent_dir/out.bag"), std::string::npos) << output;
  // A kinematics CSV that cannot be written is named.
  EXPECT_NE(runTrackBag(base + " --bag " + trial.dir.file("trial.bag") +
                            " --kinematics-csv /nonexistent_dir/k.csv",
                        &output),
            0);
  EXPECT_NE(output.find("/nonexistent_dir/k.csv"), std::string::npos) << output;
}

// Frames from an image intensifier that was calibrated but not corrected: the camera_info
// carries its pincushion (plumb_bob) and the images show it. Tracked as they come, they are as
// good as undistorted frames; the same frames with the distortion left out of camera_info are
// not.
TEST(TrackBag, RemovesTheLensDistortionThatCameraInfoCarries) {
  Trial trial(1);
  const auto distortBag = [&](const std::string& name, bool keep_coefficients) {
    rosbag::Bag in(trial.dir.file("trial.bag"));
    rosbag::Bag out(trial.dir.file(name), rosbag::bagmode::Write);
    std::optional<sensor_msgs::CameraInfo> info;
    std::vector<sensor_msgs::Image> waiting;
    const auto writeImage = [&](sensor_msgs::Image image, const ros::Time& time) {
      sensor_msgs::CameraInfo lens = *info;
      lens.distortion_model = "plumb_bob";
      lens.D = {6.0, 0.0, 0.0, 0.0, 0.0};
      const cv::Mat distorted = imaging::applyLensDistortion(ros_bridge::fromImageMessage(image),
                                                             ros_bridge::fromCameraInfo(lens),
                                                             ros_bridge::lensDistortion(lens));
      out.write("/fluoro/image_raw", time, ros_bridge::toImageMessage(distorted, image.header));
      if (!keep_coefficients) lens.D.assign(5, 0.0);
      out.write("/fluoro/camera_info", time, lens);
    };
    for (const rosbag::MessageInstance& m : rosbag::View(in)) {
      if (const auto i = m.instantiate<sensor_msgs::CameraInfo>()) {
        info = *i;
      } else if (const auto image = m.instantiate<sensor_msgs::Image>()) {
        if (info) {
          writeImage(*image, m.getTime());
        } else {
          waiting.push_back(*image);
        }
      } else {
        out.write(m.getTopic(), m.getTime(), m);
      }
      if (info) {
        for (const auto& image : waiting) writeImage(image, image.header.stamp);
        waiting.clear();
      }
    }
  };
  distortBag("distorted.bag", true);
  distortBag("uncalibrated.bag", false);
  for (const bool calibrated : {true, false}) {
    const std::string bag = calibrated ? "distorted.bag" : "uncalibrated.bag";
    std::string output;
    ASSERT_EQ(runTrackBag("--config " + trial.dir.file("trial.yaml") + " --bag " +
                              trial.dir.file(bag) + " --poses-csv " + trial.dir.file("poses.csv") +
                              " --truth-csv " + trial.dir.file("truth.csv"),
                          &output),
              0)
        << output;
    // A pincushion magnifies the implants, which a pinhole reads as nearer the source: the
    // depth shows it (in-plane the criteria pass either way near the centre of the field).
    const std::size_t at = output.find("tz (along the beam) ");
    ASSERT_NE(at, std::string::npos) << output;
    const double depth_rms_mm = std::stod(output.substr(at + 20));
    if (calibrated) {
      EXPECT_NE(output.find("8/8 frames within"), std::string::npos) << output;
      EXPECT_LT(depth_rms_mm, 3.0) << output;
    } else {
      EXPECT_GT(depth_rms_mm, 6.0) << output;
    }
  }
}

TEST(BagFrameReader, ImageTopicWithoutCameraInfoIsNamed) {
  TempDir dir;
  {
    rosbag::Bag bag(dir.file("no_info.bag"), rosbag::bagmode::Write);
    sensor_msgs::Image image;
    image.header.stamp = ros::Time(1.0);
    image.encoding = "mono8";
    image.width = image.height = image.step = 4;
    image.data.resize(16);
    bag.write("/cam/image_raw", ros::Time(1.0), image);
  }
  EXPECT_THROW_WITH(ros_bridge::BagFrameReader(dir.file("no_info.bag"), {}, ""),
                    "no camera_info for '/cam/image_raw'");
}

TEST(BagFrameReader, WrongEncodingSkipsTheFrameWithItsReasonAndKeepsTheRest) {
  TempDir dir;
  {
    rosbag::Bag bag(dir.file("mixed.bag"), rosbag::bagmode::Write);
    geometry::XrayCamera camera(4, 4, 100.0, 100.0, 1.5, 1.5, "fluoro_optical");
    for (int i = 0; i < 3; ++i) {
      const ros::Time stamp(1.0 + i);
      sensor_msgs::CameraInfo info = ros_bridge::toCameraInfo(camera, stamp);
      sensor_msgs::Image image;
      image.header = info.header;
      image.encoding = i == 1 ? "32FC1" : "mono8";
      image.width = image.height = 4;
      image.step = i == 1 ? 16 : 4;
      image.data.resize(image.step * 4);
      bag.write("/fluoro/camera_info", stamp, info);
      bag.write("/fluoro/image_raw", stamp, image);
    }
  }
  ros_bridge::BagFrameReader reader(dir.file("mixed.bag"), {}, "");
  std::vector<int> used;
  std::vector<std::string> reasons;
  reader.read([&](const ros_bridge::BagFrame& f) { used.push_back(f.index); },
              [&](int, double, const std::string& reason) { reasons.push_back(reason); });
  EXPECT_EQ(used, (std::vector<int>{0, 2}));
  ASSERT_EQ(reasons.size(), 1u);
  EXPECT_NE(reasons[0].find("encoding '32FC1'"), std::string::npos) << reasons[0];
}

// A bag recorded through image_transport's compressed transport (PNG: lossless) tracks exactly
// as the same frames stored raw.
TEST(TrackBag, TracksAPngCompressedBagExactlyAsItsRawTwin) {
  Trial raw(1, 4);
  Trial png(1, 4, ros_bridge::TrialBagWriter::Compression{});
  std::string output;
  for (const Trial* trial : {&raw, &png}) {
    ASSERT_EQ(runTrackBag("--config " + trial->dir.file("trial.yaml") + " --bag " +
                              trial->dir.file("trial.bag") + " --poses-csv " +
                              trial->dir.file("poses.csv"),
                          &output),
              0)
        << output;
    EXPECT_NE(output.find("4 frame(s), 4 tracked, 0 skipped"), std::string::npos) << output;
  }
  const auto expected = io::readPosesCsv(raw.dir.file("poses.csv"));
  const auto poses = io::readPosesCsv(png.dir.file("poses.csv"));
  ASSERT_EQ(poses.size(), 8u);
  ASSERT_EQ(poses.size(), expected.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(poses[i].bone, expected[i].bone);
    EXPECT_EQ(poses[i].status, expected[i].status);
    EXPECT_TRUE(poses[i].pose.isApprox(expected[i].pose, 1e-12))
        << poses[i].bone << " frame " << poses[i].frame;
  }
}

TEST(BagFrameReader, ReadsEachStreamOnceAndSkipsACompressedFrameThatDoesNotDecode) {
  TempDir dir;
  {
    rosbag::Bag bag(dir.file("both.bag"), rosbag::bagmode::Write);
    rosbag::Bag only(dir.file("compressed_only.bag"), rosbag::bagmode::Write);
    geometry::XrayCamera camera(6, 4, 100.0, 100.0, 2.5, 1.5, "fluoro_optical");
    for (int i = 0; i < 3; ++i) {
      const ros::Time stamp(1.0 + i);
      const sensor_msgs::CameraInfo info = ros_bridge::toCameraInfo(camera, stamp);
      const cv::Mat pixels(4, 6, CV_8UC1, cv::Scalar(10 * (i + 1)));
      sensor_msgs::CompressedImage compressed = ros_bridge::toCompressedImageMessage(
          pixels, info.header, ros_bridge::ImageCompression::kPng);
      if (i == 1) compressed.data.resize(compressed.data.size() / 2);  // cut short
      for (rosbag::Bag* b : {&bag, &only}) {
        b->write("/fluoro/camera_info", stamp, info);
        b->write("/fluoro/image_raw/compressed", stamp, compressed);
      }
      bag.write("/fluoro/image_raw", stamp, ros_bridge::toImageMessage(pixels, info.header));
    }
  }
  const auto read = [](ros_bridge::BagFrameReader& reader, std::vector<int>* used,
                       std::vector<std::string>* reasons) {
    reader.read(
        [&](const ros_bridge::BagFrame& f) {
          used->push_back(f.index);
          EXPECT_EQ(f.images[0].at<std::uint8_t>(3, 5), 10 * (f.index + 1));
        },
        [&](int, double, const std::string& reason) { reasons->push_back(reason); });
  };
  // Raw and compressed copies of one stream: the raw one, once.
  ros_bridge::BagFrameReader both(dir.file("both.bag"), {}, "");
  EXPECT_EQ(both.imageTopics(), (std::vector<std::string>{"/fluoro/image_raw"}));
  std::vector<int> used;
  std::vector<std::string> reasons;
  read(both, &used, &reasons);
  EXPECT_EQ(used, (std::vector<int>{0, 1, 2}));
  EXPECT_TRUE(reasons.empty());
  // Compressed only (or asked for): its camera_info is the raw stream's sibling; the frame that
  // does not decode is skipped with the reason, the others are used.
  for (const auto& [bag, topics] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {dir.file("compressed_only.bag"), {}},
           {dir.file("both.bag"), {"/fluoro/image_raw/compressed"}}}) {
    ros_bridge::BagFrameReader reader(bag, topics, "");
    EXPECT_EQ(reader.imageTopics(), (std::vector<std::string>{"/fluoro/image_raw/compressed"}));
    used.clear();
    reasons.clear();
    read(reader, &used, &reasons);
    EXPECT_EQ(used, (std::vector<int>{0, 2})) << bag;
    ASSERT_EQ(reasons.size(), 1u) << bag;
    EXPECT_NE(reasons[0].find("could not be decoded"), std::string::npos) << reasons[0];
  }
}
