// simulate_trial: writes a synthetic total-knee fluoroscopy trial per the public contract —
// a bag with images and camera_info (and /tf_static for bi-plane), a ground-truth poses CSV,
// a trial YAML, the implant models, and a preview image.
#include <chrono>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>

#include <unistd.h>

#include <boost/program_options.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "command_line.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/poses_csv.h"
#include "fluoro_tracker/io/trial_config.h"
#include "fluoro_tracker/ros/trial_bag_writer.h"
#include "fluoro_tracker/sim/trial_simulator.h"

namespace po = boost::program_options;
namespace fs = std::filesystem;
using namespace fluoro_tracker;

namespace {

// Up to three frames (first, deepest flexion, last) of the first view side by side at half
// size, 8-bit.
cv::Mat makePreview(const std::vector<cv::Mat>& frames) {
  std::vector<cv::Mat> tiles;
  for (const cv::Mat& frame : frames) {
    cv::Mat grey = frame;
    if (grey.depth() == CV_16U) grey.convertTo(grey, CV_8U, 1.0 / 257.0);
    cv::Mat small;
    cv::resize(grey, small, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
    tiles.push_back(small);
  }
  cv::Mat preview;
  cv::hconcat(tiles, preview);
  return preview;
}

}  // namespace

int main(int argc, char** argv) {
  po::options_description options(
      "simulate_trial: synthetic single- or bi-plane total-knee fluoroscopy trial\n\nOptions");
  std::string config_path;
  std::string output_dir;
  std::string compression_text = "none";
  int jpeg_quality = 95;
  options.add_options()("help,h", "show this help")(
      "config", po::value(&config_path), "simulator settings YAML (default: built-in defaults)")(
      "output,o", po::value(&output_dir)->default_value("trial"), "output folder")(
      "frames", po::value<int>(), "number of frames (overrides the config)")(
      "views", po::value<int>(), "1 (single plane) or 2 (bi-plane)")(
      "seed", po::value<std::uint64_t>(), "noise seed")("bit-depth", po::value<int>(), "8 or 16")(
      "implants-bright", po::bool_switch(), "render implants bright (inverted polarity)")(
      "compression", po::value(&compression_text)->default_value(compression_text),
      "none (sensor_msgs/Image), png (lossless) or jpeg (8-bit frames, lossy): stored as "
      "image_transport's compressed transport does, on .../image_raw/compressed")(
      "jpeg-quality", po::value(&jpeg_quality)->default_value(jpeg_quality),
      "JPEG quality, 1-100 (--compression jpeg)");
  po::variables_map vm;
  if (const auto exit_code = tools::parseCommandLine("simulate_trial", options, argc, argv, &vm)) {
    return *exit_code;
  }

  try {
    sim::TrialSimulatorSettings settings;
    if (!config_path.empty()) settings = sim::loadSimulatorSettings(config_path);
    if (vm.count("frames")) settings.motion.frames = vm["frames"].as<int>();
    if (vm.count("views")) settings.views = vm["views"].as<int>();
    if (vm.count("seed")) settings.seed = vm["seed"].as<std::uint64_t>();
    if (vm.count("bit-depth")) settings.detector.bit_depth = vm["bit-depth"].as<int>();
    if (vm["implants-bright"].as<bool>()) settings.detector.implants_bright = true;

    const std::optional<ros_bridge::TrialBagWriter::Compression> compression =
        ros_bridge::TrialBagWriter::compressionFromOptions(compression_text, jpeg_quality);
    const auto start = std::chrono::steady_clock::now();
    const sim::TrialSimulator simulator(settings);
    fs::create_directories(output_dir);
    const std::string out = fs::canonical(output_dir).string();
    const std::string model_dir = out + "/models";
    const std::string bag_path = out + "/trial.bag";
    const std::string truth_path = out + "/ground_truth.csv";
    const std::string yaml_path = out + "/trial.yaml";
    const std::string preview_path = out + "/preview.png";

    simulator.writeModels(model_dir);
    io::saveTrialConfig(yaml_path, simulator.trialConfig(model_dir));

    std::mt19937_64 rng(settings.seed);
    ros_bridge::TrialBagWriter bag(bag_path, simulator.views(), simulator.fixedFrame(),
                                   settings.start_stamp_s, compression);
    std::vector<io::PoseRecord> truth;
    std::vector<cv::Mat> preview_frames;
    const int frames = simulator.frameCount();
    int deepest = 0;
    double deepest_flexion = -1e9;
    for (int i = 0; i < frames; ++i) {
      const double flexion = simulator.truth(i).flexion_deg;
      if (flexion > deepest_flexion) {
        deepest_flexion = flexion;
        deepest = i;
      }
    }
    const bool interactive = isatty(STDOUT_FILENO);
    for (int i = 0; i < frames; ++i) {
      const sim::SimulatedFrame frame = simulator.render(i, &rng);
      bag.write(frame);
      truth.push_back(
          {i, frame.stamp_s, sim::TrialSimulator::kFemur, frame.femur, "ok", std::nullopt});
      truth.push_back(
          {i, frame.stamp_s, sim::TrialSimulator::kTibia, frame.tibia, "ok", std::nullopt});
      if (i == 0 || i == deepest || i == frames - 1) {
        if (preview_frames.empty() || i != 0 || frames == 1)
          preview_frames.push_back(frame.images[0]);
      }
      if ((i + 1) % 10 == 0 || i + 1 == frames) {
        // Overwrite the line on a terminal; one line per update in a log.
        std::cout << (interactive ? "\r" : "") << "simulate_trial: frame " << (i + 1) << "/"
                  << frames << (interactive ? "" : "\n") << std::flush;
      }
    }
    if (interactive) std::cout << "\n";
    bag.close();
    io::writePosesCsv(truth_path, truth);
    cv::imwrite(preview_path, makePreview(preview_frames));

    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << "simulate_trial: " << frames << " frame(s), " << simulator.views().size()
              << " view(s), " << settings.image_width << "x" << settings.image_height << " "
              << settings.detector.bit_depth << "-bit, in " << seconds << " s\n"
              << "  bag:          " << bag_path << "\n"
              << "  ground truth: " << truth_path << "\n"
              << "  trial config: " << yaml_path << "\n"
              << "  models:       " << model_dir << "\n"
              << "  preview:      " << preview_path << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "simulate_trial: error: " << e.what() << "\n";
    return 1;
  }
}
