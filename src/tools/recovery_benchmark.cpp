// recovery_benchmark: what the tracker does with a frame that shows no knee, or not the knee it
// follows, and how soon it is back (issue 7: back within 3 frames; the frame flagged; no jump
// its own quality rejects; never a non-finite pose).
//
// Each simulated trial is tracked as `track_bag --recover` tracks a bag: the trial's own YAML
// (models, contact, ligaments, registration and search settings) from frame 0's true poses, each
// frame from the previous solution, a lost frame searched at once and the following frames
// searched until no bone is lost. Every --every-th frame's image is replaced by a corruption, in
// turn:
//   blank     one grey value over the whole frame (the beam off, a saturated detector);
//   black     no signal at all (a dropped exposure);
//   noise     uniform noise over the detector's range (a frame grabber's garbage);
//   mirrored  the frame flipped left to right (a knee that is not where the motion puts it);
//   half      the lower half of the frame black (a frame cut short in transfer).
// The frames are varied as the benchmark's are (flexion range, view obliquity, polarity).
// Prints per corruption how often the frame was flagged (suspect or lost), how many frames it
// took until every bone was within the criterion again, any pose that jumped, and the frames
// on the way back that were off the criterion yet unflagged.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <boost/program_options.hpp>
#include <opencv2/core.hpp>

#include "command_line.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/trial_config.h"
#include "fluoro_tracker/io/trial_models.h"
#include "fluoro_tracker/median.h"
#include "fluoro_tracker/registration/pose_error.h"
#include "fluoro_tracker/registration/pose_search.h"
#include "fluoro_tracker/registration/registrar.h"
#include "fluoro_tracker/registration/tracker.h"
#include "fluoro_tracker/sim/trial_simulator.h"

namespace po = boost::program_options;
namespace fs = std::filesystem;
using namespace fluoro_tracker;
using geometry::Pose;

namespace {

const std::vector<std::string> kCorruptions = {"blank", "black", "noise", "mirrored", "half"};

// The image of a frame replaced by corruption `kind` (one of kCorruptions).
cv::Mat corrupt(const cv::Mat& image, const std::string& kind, std::mt19937_64* rng) {
  const double full_scale = image.depth() == CV_16U ? 65535.0 : 255.0;
  cv::Mat out = image.clone();
  if (kind == "blank") {
    out.setTo(cv::Scalar(cv::mean(image)[0]));
  } else if (kind == "black") {
    out.setTo(cv::Scalar(0));
  } else if (kind == "noise") {
    cv::RNG noise((*rng)());
    noise.fill(out, cv::RNG::UNIFORM, cv::Scalar(0), cv::Scalar(full_scale + 1));
  } else if (kind == "mirrored") {
    cv::flip(image, out, 1);
  } else if (kind == "half") {
    out.rowRange(out.rows / 2, out.rows).setTo(cv::Scalar(0));
  } else {
    throw InputError("unknown corruption '" + kind + "'");
  }
  return out;
}

bool finite(const Pose& pose) {
  return pose.matrix().allFinite();
}

// What became of one corrupted frame and the frames after it.
struct Event {
  std::string kind;
  int trial = 0;
  int frame = 0;
  std::vector<std::string> status;  // the corrupted frame's, per bone
  bool flagged = false;             // some bone suspect or lost there
  int silent_wrong = 0;  // bones at status ok there, off the criterion (a wrong pose unflagged)
  int jumps = 0;         // bones whose reported pose moved off the criterion while kept ok
  int back_after = -1;   // frames after it until every bone meets the criterion (-1: never)
  int silent_after = 0;  // frames after it, before back, off the criterion with every bone ok
  double ms = 0.0;       // the time it took, and the frames after it until back (a live node
  double back_ms = 0.0;  //   drops the frames that arrive meanwhile beyond its queue)
};

struct Tallies {
  std::vector<Event> events;
  int clean_frames = 0;  // frames neither corrupted nor still recovering from one
  int clean_within = 0;
  int non_finite = 0;
  int searched_frames = 0;
  std::vector<double> frame_ms;
};

std::string joined(const std::vector<std::string>& words) {
  std::string text;
  for (const auto& w : words) text += (text.empty() ? "" : "/") + w;
  return text;
}

void printSummary(const std::string& label, const std::vector<const Event*>& events,
                  int max_frames_back) {
  int flagged = 0, back = 0, never = 0, silent = 0, jumps = 0, slowest = 0, silent_after = 0;
  std::vector<int> after;
  std::vector<double> ms;
  std::vector<double> back_ms;
  for (const Event* e : events) {
    ms.push_back(e->ms);
    back_ms.push_back(e->back_ms);
    flagged += e->flagged ? 1 : 0;
    silent += e->silent_wrong;
    jumps += e->jumps;
    silent_after += e->silent_after;
    if (e->back_after < 0) {
      ++never;
      continue;
    }
    after.push_back(e->back_after);
    slowest = std::max(slowest, e->back_after);
    back += e->back_after <= max_frames_back ? 1 : 0;
  }
  std::sort(after.begin(), after.end());
  const int n = static_cast<int>(events.size());
  std::ios format(nullptr);
  format.copyfmt(std::cout);
  std::cout << "  " << std::left << std::setw(9) << label << std::right << std::setw(3) << n
            << " event(s): flagged " << flagged << "/" << n << ", back within " << max_frames_back
            << " frame(s) " << back << "/" << n;
  if (!after.empty()) {
    std::cout << " (median " << after[after.size() / 2] << ", max " << slowest << ")";
  }
  if (never > 0) std::cout << ", never back " << never;
  std::cout << "; wrong poses kept ok " << silent << ", jumps " << jumps
            << "; frames off the criterion at status ok before back " << silent_after
            << "; time: the frame median " << std::fixed << std::setprecision(0) << median(ms)
            << " ms (max " << *std::max_element(ms.begin(), ms.end())
            << "), the frames after it until back median " << median(back_ms) << " ms (max "
            << *std::max_element(back_ms.begin(), back_ms.end()) << ")\n";
  std::cout.copyfmt(format);  // as it was: later lines set their own
}

}  // namespace

int main(int argc, char** argv) {
  po::options_description options(
      "recovery_benchmark: how the tracker flags a corrupted frame and how soon it is back\n\n"
      "Options");
  int trials = 5;
  int frames = 60;
  int every = 12;
  int max_frames_back = 3;
  std::uint64_t seed = 7;
  std::string simulator_config;
  bool verbose = false;
  options.add_options()("help,h", "show this help")(
      "trials", po::value(&trials)->default_value(trials), "simulated trials")(
      "frames", po::value(&frames)->default_value(frames), "frames per trial (one flexion cycle)")(
      "every", po::value(&every)->default_value(every),
      "corrupt frames every, 2 x every, ... of each trial (the corruptions in turn)")(
      "seed", po::value(&seed)->default_value(seed), "random seed")(
      "simulator-config", po::value(&simulator_config),
      "simulate_trial settings (e.g. config/robustness/low_dose.yaml) instead of the defaults")(
      "max-frames-back", po::value(&max_frames_back)->default_value(max_frames_back),
      "the bar: back within this many frames")(
      "verbose", po::bool_switch(&verbose),
      "print every frame: statuses, within the criterion or off, searched, time");
  po::variables_map vm;
  if (const auto exit_code =
          tools::parseCommandLine("recovery_benchmark", options, argc, argv, &vm)) {
    return *exit_code;
  }
  try {
    if (trials < 1 || frames < 2 || every < 2 || every >= frames) {
      throw InputError("need --trials >= 1, --frames >= 2 and 2 <= --every < --frames");
    }
    const sim::TrialSimulatorSettings base = simulator_config.empty()
                                                 ? sim::TrialSimulatorSettings()
                                                 : sim::loadSimulatorSettings(simulator_config);
    if (base.views != 1) throw InputError("the benchmark simulates single-plane trials");
    const fs::path models_root =
        fs::temp_directory_path() / ("recovery_benchmark_" + std::to_string(::getpid()));
    Tallies tallies;
    std::mt19937_64 rng(seed);
    int event_count = 0;
    for (int trial = 0; trial < trials; ++trial) {
      sim::TrialSimulatorSettings s = base;
      s.motion.frames = frames;
      s.seed = seed + static_cast<std::uint64_t>(trial);
      // Varied as the benchmark's: flexion range, view obliquity, polarity.
      sim::varyBenchmarkTrial(trial, &rng, &s);
      const sim::TrialSimulator simulator(s);
      // The trial as a user has it: its models on disk and its YAML.
      const std::string models = (models_root / ("trial" + std::to_string(trial))).string();
      simulator.writeModels(models);
      const io::TrialConfig config = simulator.trialConfig(models);
      const io::TrialModels loaded = io::loadTrialModels(config);
      const auto registrar = std::make_shared<const registration::Registrar>(
          loaded.bones, config.registration, loaded.joints);
      const auto search = std::make_shared<registration::PoseSearch>(registrar, config.search);
      registration::Tracker tracker(registrar, config.initialPoses(), search);
      const Pose camera_from_fixed = simulator.views()[0].camera.worldFromCamera().inverse();
      const std::size_t bones = loaded.bones.size();

      std::mt19937_64 noise(s.seed);
      std::vector<Pose> reported_before = config.initialPoses();
      Event* open = nullptr;  // the last event, until every bone is back
      for (int f = 0; f < frames; ++f) {
        const sim::SimulatedFrame frame = simulator.render(f, &noise);
        const std::vector<Pose> truth = {frame.femur, frame.tibia};
        const bool corrupted = f > 0 && f % every == 0;
        cv::Mat image = frame.images[0];
        if (corrupted) {
          const std::string& kind =
              kCorruptions[static_cast<std::size_t>(event_count) % kCorruptions.size()];
          image = corrupt(image, kind, &noise);
          tallies.events.push_back({kind, trial, f, {}, false, 0, 0, -1, 0});
          open = &tallies.events.back();
          ++event_count;
        }
        registration::TrackedFrame tracked;
        const auto start = std::chrono::steady_clock::now();
        try {
          tracked = tracker.track({{image, simulator.views()[0].camera}});
        } catch (const InputError& e) {
          // As track_bag: the frame is reported lost at the last good poses.
          tracked.poses = tracker.poses();
          tracked.status.assign(bones, "lost");
        }
        tallies.frame_ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                .count());
        tallies.searched_frames += tracked.searched ? 1 : 0;
        bool within = true;
        std::vector<bool> bone_within(bones);
        std::ostringstream errors;  // for --verbose: each bone off the criterion
        for (std::size_t b = 0; b < bones; ++b) {
          if (!finite(tracked.poses[b])) ++tallies.non_finite;
          const registration::PoseError error =
              registration::poseError(tracked.poses[b], truth[b], camera_from_fixed);
          bone_within[b] = registration::meetsSuccessCriterion(error);
          within = within && bone_within[b];
          if (!bone_within[b]) {
            errors << std::fixed << std::setprecision(1) << " (" << loaded.bones[b].name << " "
                   << error.translation_mm.transpose() << " mm, " << error.rotation_deg.transpose()
                   << " deg)";
          }
        }
        if (corrupted) {
          Event& e = *open;
          e.ms = tallies.frame_ms.back();
          e.status = tracked.status;
          for (std::size_t b = 0; b < bones; ++b) {
            const bool ok = tracked.status[b] == "ok";
            e.flagged = e.flagged || !ok;
            if (ok && !bone_within[b]) {
              ++e.silent_wrong;
              // Moved off the criterion from where the previous frame left it.
              const bool was_within = registration::meetsSuccessCriterion(
                  registration::poseError(reported_before[b], truth[b], camera_from_fixed));
              e.jumps += was_within ? 1 : 0;
            }
          }
        } else if (open != nullptr) {
          open->back_ms += tallies.frame_ms.back();
          if (within) {
            open->back_after = f - open->frame;
            open = nullptr;
          } else if (std::all_of(tracked.status.begin(), tracked.status.end(),
                                 [](const std::string& st) { return st == "ok"; })) {
            ++open->silent_after;
          }
        } else {
          ++tallies.clean_frames;
          tallies.clean_within += within ? 1 : 0;
        }
        if (verbose) {
          std::cout << "  trial " << trial << " frame " << f << (corrupted ? " (corrupted)" : "")
                    << ": " << joined(tracked.status)
                    << (within ? ", within" : ", off" + errors.str())
                    << (tracked.searched ? ", searched" : "")
                    << (tracked.given_up.empty() ? "" : ", given up: " + tracked.given_up) << ", "
                    << std::fixed << std::setprecision(0) << tallies.frame_ms.back() << " ms\n";
        }
        reported_before = tracked.poses;
      }
      fs::remove_all(models);
    }
    fs::remove_all(models_root);

    std::cout << "recovery_benchmark: " << trials << " simulated single-plane trial(s) x " << frames
              << " frame(s)"
              << (simulator_config.empty() ? std::string() : " (" + simulator_config + ")")
              << ", seed " << seed << ", frames " << every << ", " << 2 * every
              << ", ... of each corrupted (" << tallies.events.size()
              << " events); tracked from frame 0's true poses with the trial's contact, "
                 "ligaments and recovery search; within 1 mm in-plane, 2 deg about X and Z, "
                 "3 deg about Y:\n";
    std::vector<const Event*> all;
    for (const std::string& kind : kCorruptions) {
      std::vector<const Event*> of_kind;
      for (const Event& e : tallies.events) {
        if (e.kind == kind) of_kind.push_back(&e);
      }
      if (!of_kind.empty()) printSummary(kind, of_kind, max_frames_back);
      all.insert(all.end(), of_kind.begin(), of_kind.end());
    }
    printSummary("all", all, max_frames_back);
    std::sort(tallies.frame_ms.begin(), tallies.frame_ms.end());
    std::cout << "  frames neither corrupted nor recovering: " << tallies.clean_within << "/"
              << tallies.clean_frames
              << " within the criterion; non-finite poses: " << tallies.non_finite
              << "; frames searched: " << tallies.searched_frames << "; time per frame median "
              << std::fixed << std::setprecision(1) << tallies.frame_ms[tallies.frame_ms.size() / 2]
              << " ms, max " << tallies.frame_ms.back() << " ms\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "recovery_benchmark: error: " << e.what() << "\n";
    return 1;
  }
}
