// track_bag: tracks every bone through a recorded (or simulated) fluoroscopy bag without a ROS
// master, per docs/interfaces.md: each frame is registered from the previous frame's solution
// (constant-velocity prediction), or, with --init-csv, on its own from a given guess.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>

#include <unistd.h>
#include <boost/program_options.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "command_line.h"
#include "fluoro_tracker/imaging/contour_overlay.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/jts_file.h"
#include "fluoro_tracker/io/kinematics_csv.h"
#include "fluoro_tracker/io/poses_csv.h"
#include "fluoro_tracker/io/trial_config.h"
#include "fluoro_tracker/io/trial_models.h"
#include "fluoro_tracker/registration/inlier_history.h"
#include "fluoro_tracker/registration/pose_error.h"
#include "fluoro_tracker/registration/pose_search.h"
#include "fluoro_tracker/registration/registrar.h"
#include "fluoro_tracker/registration/tracker.h"
#include "fluoro_tracker/ros/bag_frame_reader.h"
#include "fluoro_tracker/ros/result_bag.h"

namespace po = boost::program_options;
using namespace fluoro_tracker;
using geometry::Pose;

namespace {}  // namespace

int main(int argc, char** argv) {
  po::options_description options(
      "track_bag: track bones through a fluoroscopy bag (no ROS master needed)\n\nOptions");
  std::string config_path, bag_path, poses_path, kinematics_path, out_bag, init_path, truth_path,
      overlay_dir, contact_path, jts_dir;
  std::vector<std::string> image_topics;
  int overlay_every = 10;
  bool recover = false;
  options.add_options()("help,h", "show this help")("config", po::value(&config_path)->required(),
                                                    "trial YAML")(
      "bag", po::value(&bag_path)->required(), "input bag")(
      "poses-csv", po::value(&poses_path)->required(), "output poses CSV")(
      "kinematics-csv", po::value(&kinematics_path),
      "joint kinematics CSV (knee: Grood & Suntay; see README)")(
      "out-bag", po::value(&out_bag),
      "output bag: the input plus /tf, kinematics and status at every image stamp")(
      "init-csv", po::value(&init_path),
      "per-frame starting poses (poses CSV); each frame on its own")(
      "image-topic", po::value(&image_topics)->multitoken(),
      "image topic(s); default: all in the bag")("truth-csv", po::value(&truth_path),
                                                 "ground-truth poses CSV: print the accuracy")(
      "overlay-dir", po::value(&overlay_dir), "write contour overlays (PNG) here")(
      "jts-dir", po::value(&jts_dir),
      "also write each bone's poses as JointTrack <bone>.jts (first view's camera frame)")(
      "contact-csv", po::value(&contact_path),
      "per joint and frame: collision, penetration depth, area, quasi-volume, gap")(
      "overlay-every", po::value(&overlay_every)->default_value(overlay_every),
      "overlay every Nth frame")(
      "recover", po::bool_switch(&recover),
      "after a lost frame, search the next frames automatically (seeded by the last good "
      "poses) until tracking is back");
  po::variables_map vm;
  if (const auto exit_code = tools::parseCommandLine("track_bag", options, argc, argv, &vm)) {
    return *exit_code;
  }

  try {
    const io::TrialConfig config = io::loadTrialConfig(config_path);
    const io::TrialModels models = io::loadTrialModels(config);
    const std::vector<registration::BoneModel>& bones = models.bones;
    const auto registrar_ptr = std::make_shared<const registration::Registrar>(
        models.bones, config.registration, models.joints);
    const registration::Registrar& registrar = *registrar_ptr;
    std::vector<io::KinematicsRecord> kinematics;
    std::ofstream contact_csv;
    if (!contact_path.empty()) {
      contact_csv.open(contact_path);
      if (!contact_csv) throw InputError("cannot write --contact-csv '" + contact_path + "'");
      contact_csv << "frame,stamp,joint,in_collision,max_depth_mm,area_mm2,quasi_volume_mm3,"
                     "min_distance_mm,penalty\n";
    }

    // Starting poses: per-frame guesses, or the trial's initial poses then the previous frames.
    std::map<std::pair<int, std::string>, Pose> guesses;
    if (!init_path.empty()) {
      for (const auto& r : io::readPosesCsv(init_path)) guesses[{r.frame, r.bone}] = r.pose;
    }
    std::map<std::pair<int, std::string>, Pose> truth;
    if (!truth_path.empty()) {
      for (const auto& r : io::readPosesCsv(truth_path)) truth[{r.frame, r.bone}] = r.pose;
    }
    if (!overlay_dir.empty()) std::filesystem::create_directories(overlay_dir);

    ros_bridge::BagFrameReader reader(bag_path, image_topics, config.fixed_frame);
    std::unique_ptr<ros_bridge::ResultBag> result_bag;
    if (!out_bag.empty()) result_bag = std::make_unique<ros_bridge::ResultBag>(out_bag);
    // Without --init-csv, frames are tracked from the previous solutions.
    std::unique_ptr<registration::Tracker> tracker;
    if (init_path.empty()) {
      // Bones without an initial pose are found by the automatic search on the first frame;
      // with --recover, lost frames are searched again until tracking is back.
      const std::vector<Pose> initial = config.initialPoses();
      std::shared_ptr<registration::PoseSearch> search;
      if (initial.empty() || recover) {
        search = std::make_shared<registration::PoseSearch>(registrar_ptr, config.search);
      }
      tracker = std::make_unique<registration::Tracker>(registrar_ptr, initial, search);
    }
    std::vector<io::PoseRecord> records;
    std::vector<std::string> missing_guesses;
    // Per bone: frame -> pose in the first view's optical frame (for --jts-dir).
    std::vector<std::map<int, Pose>> camera_poses(bones.size());
    registration::AccuracyTally accuracy;
    int tracked = 0, skipped = 0, flagged = 0;
    const bool interactive = isatty(STDOUT_FILENO);
    const auto start = std::chrono::steady_clock::now();
    const std::size_t expected = reader.expectedFrames();
    // Frames registered from --init-csv are classified against their predecessors, as the
    // tracker classifies its own.
    registration::InlierHistory inlier_history(registrar.settings().quality);

    reader.read(
        [&](const ros_bridge::BagFrame& frame) {
          std::vector<Pose> guess = tracker && tracker->initialized()
                                        ? tracker->poses()
                                        : std::vector<Pose>(bones.size(), Pose::Identity());
          for (std::size_t b = 0; !tracker && b < bones.size(); ++b) {
            const auto it = guesses.find({frame.index, bones[b].name});
            if (it == guesses.end()) {
              // Skip this frame, keep every other: the error is reported at the end.
              missing_guesses.push_back("--init-csv has no pose for bone '" + bones[b].name +
                                        "' at frame " + std::to_string(frame.index));
              std::cerr << "track_bag: skipped frame " << frame.index << ": "
                        << missing_guesses.back() << "\n";
              ++skipped;
              return;
            }
            guess[b] = it->second;
          }
          std::vector<registration::ViewImage> views;
          for (std::size_t v = 0; v < frame.images.size(); ++v)
            views.push_back({frame.images[v], frame.cameras[v]});
          registration::RegistrationResult result;
          std::vector<std::string> status;
          try {
            if (tracker) {
              const registration::TrackedFrame tracked_frame = tracker->track(views);
              const std::string jump = registration::describeImplausibleJumps(tracked_frame, bones);
              if (!jump.empty())
                std::cerr << "track_bag: frame " << frame.index << ": " << jump << "\n";
              if (!tracked_frame.given_up.empty()) {
                std::cerr << "track_bag: frame " << frame.index
                          << " given up, every bone lost: " << tracked_frame.given_up << "\n";
              }
              result = tracked_frame.result;
              result.poses = tracked_frame.poses;  // lost bones: their last good pose
              status = tracked_frame.status;
            } else {
              result = registrar.solve(views, guess);
              status = registration::classifyBones(result, registrar.settings().quality);
              inlier_history.classify(result.quality, &status);
            }
          } catch (const InputError& e) {
            // Keep going: the frame is reported lost at its starting poses.
            std::cerr << "track_bag: frame " << frame.index << ": " << e.what() << "\n";
            if (tracker && !tracker->initialized()) {
              ++skipped;  // nothing found yet: no pose to report
              return;
            }
            result = registration::RegistrationResult();
            result.poses = guess;
            result.diverged.assign(bones.size(), true);
            status.assign(bones.size(), "lost");
          }
          bool frame_flagged = false;
          registration::TrackedFrame tracked_frame;
          tracked_frame.poses = result.poses;
          tracked_frame.status = status;
          for (std::size_t b = 0; b < bones.size(); ++b) {
            frame_flagged = frame_flagged || status[b] != "ok";
            io::PoseRecord record{frame.index,     frame.stamp_s, bones[b].name,
                                  result.poses[b], status[b],     std::nullopt};
            if (b < result.quality.size()) record.quality = result.quality[b];
            records.push_back(record);
          }
          flagged += frame_flagged ? 1 : 0;
          if (result_bag) {
            tracked_frame.result = result;
            result_bag->addFrame(frame.stamp_s, reader.fixedFrame(), registrar, tracked_frame);
          }
          const Pose camera_from_fixed = frame.cameras[0].worldFromCamera().inverse();
          for (std::size_t b = 0; b < bones.size(); ++b) {
            if (status[b] != "lost")
              camera_poses[b][frame.index] = camera_from_fixed * result.poses[b];
          }
          for (std::size_t j = 0; j < registrar.joints().size(); ++j) {
            const auto& joint = registrar.joints()[j];
            // From the poses the frame reports (a failed solve has no joint results).
            const auto coordinates =
                joint.reportedCoordinates(result.poses[joint.parent], result.poses[joint.child]);
            kinematics.push_back(
                {frame.index, frame.stamp_s, joint.name, coordinates,
                 registration::combinedStatus(status[joint.parent], status[joint.child])});
            if (contact_csv.is_open() && j < result.joints.size() && result.joints[j].has_contact) {
              const auto& c = result.joints[j].contact;
              contact_csv << frame.index << "," << std::fixed << std::setprecision(6)
                          << frame.stamp_s << "," << joint.name << "," << (c.in_collision ? 1 : 0)
                          << "," << std::setprecision(4) << c.max_depth_m * 1e3 << ","
                          << c.area_m2 * 1e6 << "," << c.quasi_volume_m3 * 1e9 << ","
                          << c.min_distance_m * 1e3 << "," << c.penalty << "\n";
            }
          }
          ++tracked;

          if (!truth.empty()) {
            const Pose camera_from_fixed = frame.cameras[0].worldFromCamera().inverse();
            std::vector<registration::PoseError> errors;
            for (std::size_t b = 0; b < bones.size(); ++b) {
              const auto it = truth.find({frame.index, bones[b].name});
              if (it == truth.end()) continue;
              errors.push_back(
                  registration::poseError(result.poses[b], it->second, camera_from_fixed));
            }
            if (!errors.empty()) accuracy.addFrame(errors);
          }
          if (!overlay_dir.empty() && frame.index % std::max(1, overlay_every) == 0) {
            char name[64];
            std::snprintf(name, sizeof(name), "/overlay_%04d.png", frame.index);
            std::vector<const imaging::SilhouetteModel*> models;
            for (const auto& bone : bones) models.push_back(bone.silhouette.get());
            cv::imwrite(overlay_dir + name,
                        imaging::drawContourOverlay(frame.images[0], frame.cameras[0], models,
                                                    result.poses));
          }
          if (tracked % 10 == 0) {
            std::cout << (interactive ? "\r" : "") << "track_bag: frame " << tracked + skipped
                      << "/" << expected << (interactive ? "" : "\n") << std::flush;
          }
        },
        [&](int index, double stamp, const std::string& reason) {
          ++skipped;
          std::cerr << "track_bag: skipped frame " << index << " (stamp " << std::fixed
                    << std::setprecision(3) << stamp << "): " << reason << "\n";
        });
    if (interactive) std::cout << "\n";
    io::writePosesCsv(poses_path, records);
    if (!kinematics_path.empty()) io::writeKinematicsCsv(kinematics_path, kinematics);
    if (result_bag) {
      result_bag->copyInput(bag_path);
      result_bag->close();
    }
    if (!jts_dir.empty()) {
      std::filesystem::create_directories(jts_dir);
      const int frames = static_cast<int>(reader.expectedFrames());
      for (std::size_t b = 0; b < bones.size(); ++b) {
        // Frames skipped or lost are NOT_OPTIMIZED rows, as JointTrack writes them.
        io::JtsPoses poses(static_cast<std::size_t>(frames));
        for (const auto& [index, pose] : camera_poses[b]) {
          if (index >= frames) poses.resize(static_cast<std::size_t>(index) + 1);
          poses[static_cast<std::size_t>(index)] = io::jointTrackFromOptical(pose);
        }
        io::writeJtsFile(jts_dir + "/" + bones[b].name + ".jts", poses);
      }
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << "track_bag: " << tracked + skipped << " frame(s), " << tracked << " tracked, "
              << skipped << " skipped, " << flagged << " flagged, " << std::fixed
              << std::setprecision(1) << (seconds > 0 ? tracked / seconds : 0.0)
              << " frames/s; poses in " << poses_path << "\n";
    if (accuracy.frames() > 0) {
      std::cout << "track_bag: accuracy against " << truth_path << ": " << accuracy.summary()
                << "\n";
    }
    if (!missing_guesses.empty()) {
      std::cerr << "track_bag: error: " << missing_guesses.front();
      if (missing_guesses.size() > 1)
        std::cerr << " (and " << missing_guesses.size() - 1 << " more)";
      std::cerr << "; those frames were skipped, the others written\n";
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "track_bag: error: " << e.what() << "\n";
    return 1;
  }
}
