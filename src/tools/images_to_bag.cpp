// images_to_bag: real fluoroscopy frames, as labs keep them (a folder of images per view and a
// JointTrack or MayaCam calibration file), written as a bag per docs/interfaces.md, so that
// track_bag and the tracking node can track them. For users coming from JointTrack it also turns
// each bone's .jts poses into a poses CSV (a reference to score against, or per-frame guesses
// for --init-csv) and writes a trial YAML whose initial poses are the first frame's.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <vector>

#include <boost/program_options.hpp>

#include "command_line.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/fluoro_view.h"
#include "fluoro_tracker/io/image_folder.h"
#include "fluoro_tracker/io/jts_file.h"
#include "fluoro_tracker/io/poses_csv.h"
#include "fluoro_tracker/io/trial_config.h"
#include "fluoro_tracker/io/view_calibration.h"
#include "fluoro_tracker/ros/trial_bag_writer.h"

namespace po = boost::program_options;
namespace fs = std::filesystem;
using namespace fluoro_tracker;

namespace {

// "name=value" options, in the order given. Throws InputError naming the option otherwise.
std::vector<std::pair<std::string, std::string>> namedValues(const std::vector<std::string>& values,
                                                             const std::string& option) {
  std::vector<std::pair<std::string, std::string>> result;
  for (const std::string& value : values) {
    const std::size_t equals = value.find('=');
    if (equals == std::string::npos || equals == 0 || equals + 1 == value.size()) {
      throw InputError("--" + option + " '" + value + "' is not BONE=FILE");
    }
    const std::string name = value.substr(0, equals);
    for (const auto& [other, unused] : result) {
      if (other == name) throw InputError("--" + option + " names bone '" + name + "' twice");
    }
    result.emplace_back(name, value.substr(equals + 1));
  }
  return result;
}

struct ViewInput {
  std::vector<std::string> files;
  io::ViewCalibration calibration;
  cv::Mat first;  // the first frame, read for the view's size; written with frame 0
  int width = 0;
  int height = 0;
};

}  // namespace

int main(int argc, char** argv) {
  po::options_description options(
      "images_to_bag: a bag of real fluoroscopy frames (an image folder and a calibration per "
      "view) for track_bag and the tracking node\n\nOptions");
  std::vector<std::string> image_dirs, calibration_paths, jts_args, mesh_args;
  std::string output_path, reference_path, trial_yaml_path, mesh_units_text = "mm";
  std::string compression_text = "none";
  int jpeg_quality = 95;
  double rate_hz = 30.0;
  double start_stamp_s = 1.0;
  options.add_options()("help,h", "show this help")(
      "images", po::value(&image_dirs)->required(),
      "folder of one view's frames (.tif, .png, ...; natural file order); repeat per view")(
      "calibration", po::value(&calibration_paths)->required(),
      "that view's calibration: JointTrack (JT_INTCALIB, JT_CALIB_INT_EXT) or MayaCam 2.0; "
      "one per --images, in the same order")("output,o", po::value(&output_path)->required(),
                                             "bag to write")(
      "rate-hz", po::value(&rate_hz)->default_value(rate_hz), "frame rate of the stamps")(
      "start-stamp-s", po::value(&start_stamp_s)->default_value(start_stamp_s),
      "stamp of the first frame (bags cannot hold 0)")(
      "compression", po::value(&compression_text)->default_value(compression_text),
      "none (sensor_msgs/Image), png (lossless) or jpeg (8-bit frames, lossy): png and jpeg are "
      "stored as image_transport's compressed transport does, on .../image_raw/compressed")(
      "jpeg-quality", po::value(&jpeg_quality)->default_value(jpeg_quality),
      "JPEG quality, 1-100 (--compression jpeg)")(
      "jts", po::value(&jts_args),
      "BONE=FILE: a bone's JointTrack poses (.jts, one row per "
      "frame in file order, first view's camera frame); repeat per bone")(
      "reference-csv", po::value(&reference_path),
      "write the --jts poses as a poses CSV (for track_bag --truth-csv or --init-csv)")(
      "mesh", po::value(&mesh_args),
      "BONE=FILE: a bone's model, for --trial-yaml; repeat per bone")(
      "mesh-units", po::value(&mesh_units_text)->default_value(mesh_units_text),
      "units of the --mesh files: mm or m")(
      "trial-yaml", po::value(&trial_yaml_path),
      "write a trial YAML with the --mesh bones, their initial poses from the first frame's "
      "--jts row (a bone without one: found automatically), and no joints");
  po::variables_map vm;
  if (const auto exit_code = tools::parseCommandLine("images_to_bag", options, argc, argv, &vm)) {
    return *exit_code;
  }

  try {
    if (image_dirs.size() != calibration_paths.size()) {
      throw InputError(std::to_string(image_dirs.size()) + " --images folder(s) but " +
                       std::to_string(calibration_paths.size()) +
                       " --calibration file(s): give one calibration per view");
    }
    if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) {
      throw InputError("--rate-hz must be a positive number");
    }
    if (!(start_stamp_s > 0.0) || !std::isfinite(start_stamp_s)) {
      throw InputError("--start-stamp-s must be positive (bags cannot hold time 0)");
    }
    const std::optional<ros_bridge::TrialBagWriter::Compression> compression =
        ros_bridge::TrialBagWriter::compressionFromOptions(compression_text, jpeg_quality);
    const auto jts_files = namedValues(jts_args, "jts");
    const auto mesh_files = namedValues(mesh_args, "mesh");
    if (!reference_path.empty() && jts_files.empty()) {
      throw InputError("--reference-csv needs the poses of at least one bone (--jts BONE=FILE)");
    }
    if (!trial_yaml_path.empty() && mesh_files.empty()) {
      throw InputError("--trial-yaml needs at least one bone model (--mesh BONE=FILE)");
    }
    if (trial_yaml_path.empty() && !mesh_files.empty()) {
      throw InputError("--mesh is used only with --trial-yaml");
    }
    const geometry::LengthUnit mesh_units =
        geometry::parseLengthUnit(mesh_units_text, "--mesh-units");

    // Each view: its frames, their size (from the first) and its calibration.
    const std::size_t view_count = image_dirs.size();
    std::vector<ViewInput> inputs(view_count);
    std::vector<io::FluoroView> views;
    for (std::size_t v = 0; v < view_count; ++v) {
      ViewInput& input = inputs[v];
      input.files = io::listImageFiles(image_dirs[v]);
      input.first = io::readFluoroImage(input.files.front());
      input.width = input.first.cols;
      input.height = input.first.rows;
      const std::string name = io::fluoroViewName(v, view_count);
      input.calibration = io::loadViewCalibration(calibration_paths[v], input.width, input.height,
                                                  io::opticalFrameId(name));
      geometry::XrayCamera camera = input.calibration.camera;
      if (view_count == 1) {
        // One view: its optical frame is the fixed frame.
        camera.setWorldFromCamera(geometry::Pose::Identity());
      } else if (!input.calibration.has_extrinsics) {
        throw InputError("calibration '" + calibration_paths[v] +
                         "' has no extrinsics: several views need each view's pose in a common "
                         "lab frame (JT_CALIB_INT_EXT or MayaCam 2.0)");
      }
      if (inputs[v].files.size() != inputs[0].files.size()) {
        throw InputError("view " + std::to_string(v + 1) + " ('" + image_dirs[v] + "') has " +
                         std::to_string(inputs[v].files.size()) + " frame(s), view 1 ('" +
                         image_dirs[0] + "') " + std::to_string(inputs[0].files.size()) +
                         ": every view needs one image per frame");
      }
      views.push_back({name, camera, {}});  // frames corrected already, or a pinhole
    }
    const int frames = static_cast<int>(inputs[0].files.size());
    const auto stampOf = [&](int frame) { return start_stamp_s + frame / rate_hz; };

    // The bones' JointTrack poses, in the trial's fixed frame.
    std::map<std::string, std::vector<std::optional<geometry::Pose>>> reference;
    for (const auto& [bone, path] : jts_files) {
      if (inputs[0].calibration.format != io::CalibrationFormat::kJointTrack) {
        throw InputError(
            "--jts poses are in JointTrack's camera frame: the first view's "
            "calibration must be JointTrack's");
      }
      const io::JtsPoses rows = io::readJtsFile(path);
      if (static_cast<int>(rows.size()) != frames) {
        throw InputError(".jts file '" + path + "' has " + std::to_string(rows.size()) +
                         " row(s) for " + std::to_string(frames) +
                         " frame(s): JointTrack writes one row per image, in file order");
      }
      auto& poses = reference[bone];
      for (const auto& row : rows) {
        if (row) {
          poses.push_back(views[0].camera.worldFromCamera() * io::opticalFromJointTrack(*row));
        } else {
          poses.push_back(std::nullopt);
        }
      }
    }

    fs::path output(output_path);
    if (output.has_parent_path()) fs::create_directories(output.parent_path());
    ros_bridge::TrialBagWriter bag(output_path, views, io::fixedFrameId(view_count), start_stamp_s,
                                   compression);
    for (int f = 0; f < frames; ++f) {
      std::vector<cv::Mat> images;
      for (std::size_t v = 0; v < view_count; ++v) {
        const std::string& file = inputs[v].files[static_cast<std::size_t>(f)];
        cv::Mat image = f == 0 ? std::move(inputs[v].first) : io::readFluoroImage(file);
        if (image.cols != inputs[v].width || image.rows != inputs[v].height) {
          throw InputError("image '" + file + "' is " + std::to_string(image.cols) + "x" +
                           std::to_string(image.rows) + ", the view's first frame " +
                           std::to_string(inputs[v].width) + "x" +
                           std::to_string(inputs[v].height));
        }
        images.push_back(std::move(image));
      }
      bag.write(f, stampOf(f), images);
    }
    bag.close();

    if (!reference_path.empty()) {
      std::vector<io::PoseRecord> records;
      for (int f = 0; f < frames; ++f) {
        for (const auto& [bone, path] : jts_files) {
          const auto& pose = reference[bone][static_cast<std::size_t>(f)];
          if (pose) records.push_back({f, stampOf(f), bone, *pose, "ok", std::nullopt});
        }
      }
      io::writePosesCsv(reference_path, records);
    }

    std::vector<std::string> found_automatically;
    if (!trial_yaml_path.empty()) {
      io::TrialConfig trial;
      trial.fixed_frame = io::fixedFrameId(view_count);
      for (const auto& [bone, mesh] : mesh_files) {
        io::BoneConfig config;
        config.name = bone;
        config.mesh = fs::absolute(mesh).lexically_normal().string();
        if (!fs::is_regular_file(config.mesh)) {
          throw InputError("--mesh " + bone + "=" + mesh + ": no such file");
        }
        config.mesh_units = mesh_units;
        const auto it = reference.find(bone);
        if (it != reference.end() && it->second.front()) config.initial_pose = it->second.front();
        if (!config.initial_pose) found_automatically.push_back(bone);
        trial.bones.push_back(config);
      }
      for (const auto& [bone, path] : jts_files) {
        if (!trial.findBone(bone)) {
          throw InputError("--jts names bone '" + bone + "', which has no --mesh");
        }
      }
      io::saveTrialConfig(trial_yaml_path, trial);
    }

    std::cout << "images_to_bag: " << frames << " frame(s), " << view_count << " view(s)";
    for (std::size_t v = 0; v < view_count; ++v) {
      std::cout << (v == 0 ? " (" : ", ") << views[v].name << ": " << inputs[v].width << "x"
                << inputs[v].height << ", "
                << io::calibrationFormatName(inputs[v].calibration.format) << " calibration";
    }
    std::cout << "), " << rate_hz << " Hz\n  bag:           " << output_path;
    if (compression) std::cout << " (" << compression_text << " compressed)";
    std::cout << "\n";
    if (!reference_path.empty()) std::cout << "  reference CSV: " << reference_path << "\n";
    if (!trial_yaml_path.empty()) {
      std::cout << "  trial YAML:    " << trial_yaml_path << "\n";
      if (!found_automatically.empty()) {
        std::cout << "  no first-frame pose for";
        for (const auto& bone : found_automatically) std::cout << " " << bone;
        std::cout << ": every bone is then found by the automatic search on the first frame\n";
      }
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "images_to_bag: error: " << e.what() << "\n";
    return 1;
  }
}
