// benchmark: the dissertation's evaluation protocol (chapter 3) for the registration core.
//
// Simulated: trials of a total knee are simulated; every frame is registered on its own from the
// true poses perturbed uniformly by +-2 mm in-plane, +-3 mm out-of-plane and +-3 deg about each
// bone axis. A frame fails if any bone is off by more than 1 mm in-plane, 2 deg about X or Z, or
// 3 deg about Y. Prints success rate, RMS error per degree of freedom over successful frames,
// time per frame and cost evaluations per frame.
//
// Real: the three JointTrack Kneel frames with their reference poses, registered from
// perturbed references; prints the distance to the reference.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <random>
#include <sstream>

#include <boost/program_options.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../io/text_lines.h"
#include "command_line.h"
#include "fluoro_tracker/constraints/articular_contact.h"
#include "fluoro_tracker/imaging/contour_overlay.h"
#include "fluoro_tracker/imaging/lens_distortion.h"
#include "fluoro_tracker/imaging/projection_similarity.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/jointtrack_calibration.h"
#include "fluoro_tracker/io/jts_file.h"
#include "fluoro_tracker/kinematics/knee_coordinates.h"
#include "fluoro_tracker/registration/inlier_history.h"
#include "fluoro_tracker/registration/pose_error.h"
#include "fluoro_tracker/registration/pose_search.h"
#include "fluoro_tracker/registration/registrar.h"
#include "fluoro_tracker/sim/trial_simulator.h"

namespace po = boost::program_options;
using namespace fluoro_tracker;
using geometry::Pose;

namespace {

using registration::PoseError;
using registration::poseError;

// "a,b,c" as numbers; `option` names the option in errors.
std::vector<double> commaSeparatedNumbers(const std::string& text, const std::string& option) {
  std::vector<double> numbers;
  std::stringstream list(text);
  for (std::string item; std::getline(list, item, ',');) {
    numbers.push_back(io::detail::parseNumbers(item, 1, option)[0]);
  }
  return numbers;
}

Pose perturb(const Pose& truth, const Pose& camera_from_fixed, std::mt19937_64* rng,
             double in_plane_mm, double out_of_plane_mm, double rotation_deg) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const Eigen::Vector3d shift_camera(in_plane_mm * unit(*rng), in_plane_mm * unit(*rng),
                                     out_of_plane_mm * unit(*rng));
  Pose p = truth;
  p.translation() += camera_from_fixed.linear().transpose() * (1e-3 * shift_camera);
  p.linear() = truth.linear() * geometry::rotationX(geometry::degToRad(rotation_deg * unit(*rng))) *
               geometry::rotationY(geometry::degToRad(rotation_deg * unit(*rng))) *
               geometry::rotationZ(geometry::degToRad(rotation_deg * unit(*rng)));
  return p;
}

// The dissertation's crude-guess protocol (chapter 4): femur +-3 mm in-plane, +-20 mm
// out-of-plane, +-5 deg about each axis; tibia +-3 mm in-plane, +-50 mm out-of-plane, +-5 deg
// about the beam and +-10 deg about the two in-plane axes.
Pose perturbCrude(const Pose& truth, const Pose& camera_from_fixed, std::mt19937_64* rng,
                  bool tibia) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double out_of_plane_mm = tibia ? 50.0 : 20.0;
  const Eigen::Vector3d shift_camera(3.0 * unit(*rng), 3.0 * unit(*rng),
                                     out_of_plane_mm * unit(*rng));
  const double in_plane_axes_deg = tibia ? 10.0 : 5.0;
  const Eigen::Matrix3d turn_camera =
      geometry::rotationX(geometry::degToRad(in_plane_axes_deg * unit(*rng))) *
      geometry::rotationY(geometry::degToRad(in_plane_axes_deg * unit(*rng))) *
      geometry::rotationZ(geometry::degToRad(5.0 * unit(*rng)));
  const Eigen::Matrix3d c = camera_from_fixed.linear();
  Pose p = truth;
  p.translation() += c.transpose() * (1e-3 * shift_camera);
  p.linear() = c.transpose() * turn_camera * c * truth.linear();
  return p;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * (v.size() - 1) + 0.5)];
}

// "  <what>: median |error| / sd ..., beyond 2 sd ... %", against a calibrated Gaussian's 0.67
// and 4.6 %; nothing when there are no scores.
void printCalibration(const std::string& what, const std::vector<double>& z_scores) {
  if (z_scores.empty()) return;
  const double beyond_two =
      std::count_if(z_scores.begin(), z_scores.end(), [](double z) { return z > 2.0; });
  std::cout << std::setprecision(2) << "  " << what << ": median |error| / sd "
            << percentile(z_scores, 0.5) << " (0.67 if calibrated), beyond 2 sd "
            << std::setprecision(1) << 100.0 * beyond_two / z_scores.size() << " % (4.6 %)\n";
}

struct Tally {
  registration::SuccessCriterion criterion = registration::kChapter3Criterion;
  // Knee coordinates of the result against the truth's, successful frames: flexion,
  // adduction, internal rotation (deg), x, y, z (mm).
  Eigen::Matrix<double, 6, 1> joint_sum_squares = Eigen::Matrix<double, 6, 1>::Zero();
  int joint_samples = 0;
  int frames = 0;
  int successes = 0;
  std::vector<double> milliseconds;
  std::vector<double> evaluations;
  Eigen::Matrix<double, 6, 1> sum_squares = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 1> sum = Eigen::Matrix<double, 6, 1>::Zero();
  int samples = 0;                                            // bone-frames in successful frames
  std::vector<Eigen::Matrix<double, 6, 1>> bone_sum_squares;  // per bone, successful frames
  // Second bone's position relative to the first, error in the view's axes (mm), all frames:
  // what joint kinematics see, and what contact constrains.
  Eigen::Vector3d relative_sum_squares = Eigen::Vector3d::Zero();
  Eigen::Vector3d relative_sum = Eigen::Vector3d::Zero();
  // Contact at the result: frames whose surfaces interpenetrate more than 0.5 mm.
  int deep_penetrations = 0;
  // Projection similarity (grey + edge NCC, view 1) at the result and at the truth.
  std::vector<double> similarity_result;
  std::vector<double> similarity_truth;
  int failed_frames_scored_below_truth = 0;
  // Failures per bone and criterion: in-plane translation, rotation about X, Y, Z.
  std::vector<std::array<int, 4>> failures;
  // The quality status (registration::classifyBones) against the truth: frames with any bone
  // flagged suspect or lost, among failed and among successful frames.
  int failed_flagged = 0;
  int good_flagged = 0;
  // Successful frames (the criteria leave the beam direction out) with a bone more than
  // kFarAlongBeamMm off along the beam, and how many of them were flagged.
  static constexpr double kFarAlongBeamMm = 5.0;
  int good_far_along_beam = 0;
  int good_far_along_beam_flagged = 0;

  void addStatus(const std::vector<std::string>& status, bool success,
                 const std::vector<PoseError>& errors) {
    const bool flagged =
        std::any_of(status.begin(), status.end(), [](const std::string& s) { return s != "ok"; });
    if (flagged && success) ++good_flagged;
    if (flagged && !success) ++failed_flagged;
    const bool far_along_beam = std::any_of(errors.begin(), errors.end(), [](const PoseError& e) {
      return std::abs(e.translation_mm.z()) > kFarAlongBeamMm;
    });
    if (success && far_along_beam) {
      ++good_far_along_beam;
      if (flagged) ++good_far_along_beam_flagged;
    }
  }

  // |error along the beam| / reported standard deviation, every bone-frame with a covariance:
  // for a calibrated Gaussian, median 0.67 and 4.6 % beyond 2.
  std::vector<double> out_of_plane_z_scores;
  // The same about each bone's own X, Y and Z axes: |rotation error| / standard deviation.
  std::array<std::vector<double>, 3> rotation_z_scores;
  void addUncertainty(const registration::RegistrationResult& result,
                      const std::vector<PoseError>& errors) {
    for (std::size_t b = 0; b < errors.size() && b < result.quality.size(); ++b) {
      const double sd_mm = 1e3 * result.quality[b].out_of_plane_sd_m;
      if (sd_mm > 0.0)
        out_of_plane_z_scores.push_back(std::abs(errors[b].translation_mm.z()) / sd_mm);
      if (b >= result.covariance_valid.size() || !result.covariance_valid[b]) continue;
      // The covariance's rotation is of the fixed frame's rotation vector; the error's is the
      // bone's (truth^-1 * estimate), so carry the covariance into the bone's axes.
      const Eigen::Matrix3d axes = result.poses[b].linear();
      const Eigen::Matrix3d in_bone =
          axes.transpose() * result.covariances[b].block<3, 3>(3, 3) * axes;
      for (int a = 0; a < 3; ++a) {
        const double sd_deg = geometry::radToDeg(std::sqrt(std::max(0.0, in_bone(a, a))));
        if (sd_deg > 0.0)
          rotation_z_scores[a].push_back(std::abs(errors[b].rotation_deg(a)) / sd_deg);
      }
    }
  }

  void addSimilarity(double at_result, double at_truth, bool success) {
    similarity_result.push_back(at_result);
    similarity_truth.push_back(at_truth);
    if (!success && at_result < at_truth) ++failed_frames_scored_below_truth;
  }

  bool succeeded(const std::vector<PoseError>& errors) const {
    return std::all_of(errors.begin(), errors.end(), [this](const PoseError& e) {
      return registration::meetsSuccessCriterion(e, criterion);
    });
  }

  void addJoint(const kinematics::KneeCoordinates& result,
                const kinematics::KneeCoordinates& truth) {
    Eigen::Matrix<double, 6, 1> e;
    e << geometry::radToDeg(result.flexion_rad - truth.flexion_rad),
        geometry::radToDeg(result.adduction_rad - truth.adduction_rad),
        geometry::radToDeg(result.internal_rotation_rad - truth.internal_rotation_rad),
        1e3 * (result.x_m - truth.x_m), 1e3 * (result.y_m - truth.y_m),
        1e3 * (result.z_m - truth.z_m);
    joint_sum_squares += e.cwiseProduct(e);
    ++joint_samples;
  }

  void addRelative(const Eigen::Vector3d& error_mm) {
    relative_sum_squares += error_mm.cwiseProduct(error_mm);
    relative_sum += error_mm;
  }

  void add(const std::vector<PoseError>& errors, double ms, int cost_evaluations) {
    ++frames;
    milliseconds.push_back(ms);
    evaluations.push_back(cost_evaluations);
    failures.resize(errors.size(), std::array<int, 4>{});
    for (std::size_t b = 0; b < errors.size(); ++b) {
      const PoseError& e = errors[b];
      if (std::abs(e.translation_mm.x()) > criterion.in_plane_mm ||
          std::abs(e.translation_mm.y()) > criterion.in_plane_mm)
        ++failures[b][0];
      if (std::abs(e.rotation_deg.x()) > criterion.xz_deg) ++failures[b][1];
      if (std::abs(e.rotation_deg.y()) > criterion.y_deg) ++failures[b][2];
      if (std::abs(e.rotation_deg.z()) > criterion.xz_deg) ++failures[b][3];
    }
    if (!succeeded(errors)) return;
    ++successes;
    bone_sum_squares.resize(errors.size(), Eigen::Matrix<double, 6, 1>::Zero());
    for (std::size_t b = 0; b < errors.size(); ++b) {
      const PoseError& e = errors[b];
      Eigen::Matrix<double, 6, 1> v;
      v << e.translation_mm, e.rotation_deg;
      bone_sum_squares[b] += v.cwiseProduct(v);
      sum_squares += v.cwiseProduct(v);
      sum += v;
      ++samples;
    }
  }

  void print(const std::string& title) const {
    std::cout << title << "\n  frames " << frames << ", success " << std::fixed
              << std::setprecision(1) << 100.0 * successes / std::max(frames, 1) << " %\n";
    if (samples > 0) {
      const Eigen::Matrix<double, 6, 1> rms = (sum_squares / samples).cwiseSqrt();
      std::cout << std::setprecision(2) << "  RMS (successful frames, both bones): tx " << rms[0]
                << " mm, ty " << rms[1] << " mm, tz " << rms[2] << " mm, rx " << rms[3]
                << " deg, ry " << rms[4] << " deg, rz " << rms[5] << " deg\n";
      for (std::size_t b = 0; b < bone_sum_squares.size(); ++b) {
        const Eigen::Matrix<double, 6, 1> bone = (bone_sum_squares[b] / successes).cwiseSqrt();
        std::cout << "  RMS bone " << b << ": tx " << bone[0] << " mm, ty " << bone[1] << " mm, tz "
                  << bone[2] << " mm, rx " << bone[3] << " deg, ry " << bone[4] << " deg, rz "
                  << bone[5] << " deg\n";
      }
      const Eigen::Matrix<double, 6, 1> mean = sum / samples;
      std::cout << "  mean error: tx " << mean[0] << " mm, ty " << mean[1] << " mm, tz " << mean[2]
                << " mm, rx " << mean[3] << " deg, ry " << mean[4] << " deg, rz " << mean[5]
                << " deg\n";
    }
    if (frames > 0 && relative_sum_squares.squaredNorm() > 0.0) {
      const Eigen::Vector3d rms = (relative_sum_squares / frames).cwiseSqrt();
      const Eigen::Vector3d mean = relative_sum / frames;
      std::cout << std::setprecision(2) << "  tibia relative to femur (all frames): RMS x "
                << rms.x() << " mm, y " << rms.y() << " mm, z (out-of-plane) " << rms.z()
                << " mm; mean z " << mean.z()
                << " mm; frames penetrating > 0.5 mm: " << deep_penetrations << "\n";
    }
    if (joint_samples > 0) {
      const Eigen::Matrix<double, 6, 1> rms = (joint_sum_squares / joint_samples).cwiseSqrt();
      std::cout << std::setprecision(2) << "  knee kinematics RMS (successful frames): flexion "
                << rms[0] << " deg, adduction " << rms[1] << " deg, internal rotation " << rms[2]
                << " deg, x (anterior) " << rms[3] << " mm, y (superior) " << rms[4]
                << " mm, z (medial-lateral) " << rms[5] << " mm\n";
    }
    for (std::size_t b = 0; b < failures.size(); ++b) {
      std::cout << "  bone " << b << " out of bounds in frames: in-plane " << failures[b][0]
                << ", rx " << failures[b][1] << ", ry " << failures[b][2] << ", rz "
                << failures[b][3] << "\n";
    }
    if (!similarity_result.empty()) {
      std::cout << std::setprecision(3) << "  projection similarity (grey + edge NCC): median "
                << percentile(similarity_result, 0.5) << " at the result, "
                << percentile(similarity_truth, 0.5)
                << " at the truth; failed frames scoring below "
                << "their truth: " << failed_frames_scored_below_truth << "/" << frames - successes
                << "\n";
    }
    std::cout << std::setprecision(1) << "  status flags (suspect or lost): " << failed_flagged
              << "/" << frames - successes << " failed frames ("
              << 100.0 * failed_flagged / std::max(1, frames - successes) << " %), " << good_flagged
              << "/" << successes << " successful frames ("
              << 100.0 * good_flagged / std::max(1, successes) << " %); of the successful frames, "
              << good_far_along_beam_flagged << "/" << good_far_along_beam
              << " with a bone more than " << kFarAlongBeamMm
              << " mm off along the beam were flagged\n";
    printCalibration("out-of-plane standard deviation against the error along the beam",
                     out_of_plane_z_scores);
    for (int a = 0; a < 3; ++a) {
      printCalibration(std::string("rotational standard deviation about the bone's ") + "XYZ"[a] +
                           " axis against its error",
                       rotation_z_scores[a]);
    }
    std::cout << std::setprecision(1) << "  time per frame: median "
              << percentile(milliseconds, 0.5) << " ms, p95 " << percentile(milliseconds, 0.95)
              << " ms; cost evaluations per frame: median " << percentile(evaluations, 0.5) << "\n";
  }
};

// Bone b's estimated edge offset in the first view (full-resolution pixels, + inward); null
// when the registration estimated none.
const double* firstViewEdgeOffset(const registration::RegistrationResult& result, std::size_t b) {
  if (b >= result.edge_offsets_px.size() || result.edge_offsets_px[b].empty()) return nullptr;
  return &result.edge_offsets_px[b][0];
}

std::vector<registration::BoneModel> boneModels(const std::vector<const geometry::Mesh*>& meshes,
                                                const std::vector<std::string>& names) {
  std::vector<registration::BoneModel> bones;
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    bones.push_back({names[i], std::make_shared<imaging::SilhouetteModel>(*meshes[i]), 1.0});
  }
  return bones;
}

struct Perturbation {
  double in_plane_mm = 2.0;
  double out_of_plane_mm = 3.0;
  double rotation_deg = 3.0;
  bool crude = false;   // chapter 4's per-bone crude guesses instead (perturbCrude)
  bool search = false;  // no guess at all: automatic initialisation (registration::PoseSearch)
  registration::PoseSearchSettings search_settings;
};

// Which simulated images: "good" (1024x1024, the simulator's defaults) or "poor" (768x768,
// 8-bit, a quarter of the quanta, and a metal rod across the tibial component, like the
// dissertation's Dataset B).
void applyTrialSet(const std::string& name, sim::TrialSimulatorSettings* s) {
  if (name == "good") return;
  if (name != "poor") throw InputError("--trial-set must be good or poor, not '" + name + "'");
  s->pixel_spacing_mm *= s->image_width / 768.0;
  s->image_width = 768;
  s->image_height = 768;
  s->detector.bit_depth = 8;
  s->detector.photons_per_pixel /= 4.0;
  s->occluder_rod_radius_mm = 2.5;
}

// One registration set-up compared in the benchmark (a row of Table 3-1).
struct Condition {
  std::string name;
  bool contact = false;
  bool keep_in_contact = false;
  bool ligaments = false;
};

// The knee joint between the simulator's femoral component (bone 0) and tibial tray (bone 1):
// contact of the femoral component with the insert, and optionally a stay-in-contact term.
registration::JointModel kneeJoint(const geometry::Mesh& femoral_component,
                                   const geometry::Mesh& insert, kinematics::Side side,
                                   const constraints::ContactSettings& settings,
                                   const constraints::LigamentSettings& ligaments,
                                   const Condition& condition) {
  registration::JointModel knee;
  knee.name = "knee";
  knee.parent = 0;
  knee.child = 1;
  knee.side = side;
  knee.ligaments = ligaments;
  knee.ligaments.enabled = condition.ligaments;
  if (condition.contact) {
    knee.contact =
        std::make_shared<constraints::ArticularContact>(femoral_component, insert, settings);
  }
  return knee;
}

std::vector<registration::JointModel> kneeJoints(const geometry::Mesh& femoral_component,
                                                 const geometry::Mesh& insert,
                                                 kinematics::Side side,
                                                 const constraints::ContactSettings& settings,
                                                 const constraints::LigamentSettings& ligaments,
                                                 const Condition& condition) {
  if (!condition.contact && !condition.ligaments) return {};
  std::vector<registration::JointModel> joints = {
      kneeJoint(femoral_component, insert, side, settings, ligaments, condition)};
  if (condition.keep_in_contact) {
    Condition contact_only = condition;
    contact_only.ligaments = false;
    joints.push_back(kneeJoint(femoral_component, insert, side,
                               constraints::stayInContactSettings(settings, settings.weight),
                               ligaments, contact_only));
  }
  return joints;
}

// What runSimulated writes besides its printed figures.
struct BenchmarkOutputs {
  std::ostream* quality_csv = nullptr;  // per registration and bone
  std::string failure_overlay_dir;      // empty: no overlays
};

// `base`: the simulator settings every trial starts from (then varied per trial: flexion range,
// view obliquity, polarity; and by the trial set).
void runSimulated(const sim::TrialSimulatorSettings& base, int trials, int frames, int views,
                  std::uint64_t seed, bool ideal_images, const std::string& trial_set,
                  const Perturbation& perturbation,
                  const registration::RegistrationSettings& settings,
                  const std::vector<Condition>& conditions,
                  const constraints::ContactSettings& contact_settings,
                  const constraints::LigamentSettings& ligament_settings,
                  const BenchmarkOutputs& outputs) {
  std::ostream* quality_csv = outputs.quality_csv;
  if (quality_csv != nullptr) {
    *quality_csv
        << "condition,trial,frame,bone,bone_success,frame_success,inlier_fraction,"
           "contour_rms_px,penetration_mm,envelope_violation,out_of_plane_sd_mm,"
           "rotation_sd_deg,status,error_x_mm,error_y_mm,error_z_mm,error_rx_deg,error_ry_deg,"
           "error_rz_deg,flexion_deg,adduction_deg,internal_rotation_deg,true_flexion_deg,"
           "true_adduction_deg,true_internal_rotation_deg,edge_offset_px,contour_spread_px,"
           "offset_inlier_fraction\n";
  }
  std::vector<Tally> tallies(conditions.size());
  for (Tally& t : tallies) {
    t.criterion =
        perturbation.crude ? registration::kChapter4Criterion : registration::kChapter3Criterion;
  }
  std::mt19937_64 rng(seed);
  for (int trial = 0; trial < trials; ++trial) {
    sim::TrialSimulatorSettings s = base;
    s.views = views;
    s.motion.frames = frames;
    s.seed = seed + trial;
    sim::varyBenchmarkTrial(trial, &rng, &s);  // flexion range, view obliquity, polarity
    if (ideal_images) {
      s.anatomy = false;
      s.detector.photons_per_pixel = 0.0;
    }
    applyTrialSet(trial_set, &s);
    const sim::TrialSimulator simulator(s);
    const auto& implants = simulator.implants();
    std::vector<std::shared_ptr<registration::Registrar>> registrars;
    for (const Condition& condition : conditions) {
      registrars.push_back(std::make_shared<registration::Registrar>(
          boneModels({&implants.femoral_component, &implants.tibial_tray}, {"femur", "tibia"}),
          settings,
          kneeJoints(implants.femoral_component, implants.tibial_insert, s.side, contact_settings,
                     ligament_settings, condition)));
    }
    std::vector<std::unique_ptr<registration::PoseSearch>> searches;
    if (perturbation.search) {
      for (const auto& registrar : registrars) {
        searches.push_back(
            std::make_unique<registration::PoseSearch>(registrar, perturbation.search_settings));
      }
    }
    // Each condition's frames of this trial in order, as the tracker would see them: the
    // status also compares each bone with its recent frames.
    std::vector<registration::InlierHistory> inlier_histories(
        conditions.size(), registration::InlierHistory(settings.quality));
    // Measures penetration at every result, with or without contact in the registration.
    const constraints::ArticularContact penetration_probe(implants.femoral_component,
                                                          implants.tibial_insert, contact_settings);
    std::vector<registration::ViewImage> view_images;
    for (const auto& v : simulator.views()) view_images.push_back({cv::Mat(), v.camera});
    // Frames with an image intensifier's distortion are corrected as the node corrects them.
    std::vector<std::optional<imaging::LensMaps>> undistortion(view_images.size());
    for (std::size_t v = 0; v < view_images.size(); ++v) {
      const auto& view = simulator.views()[v];
      if (view.distortion.distorts())
        undistortion[v] = imaging::undistortionMaps(view.camera, view.distortion);
    }
    const Pose camera_from_fixed = simulator.views()[0].camera.worldFromCamera().inverse();
    const imaging::EdgeMapSettings edge_settings = settings.edges;
    for (int f = 0; f < frames; ++f) {
      sim::SimulatedFrame frame = simulator.render(f, &rng);
      for (std::size_t v = 0; v < view_images.size(); ++v) {
        if (undistortion[v])
          frame.images[v] = imaging::remapThroughLens(frame.images[v], *undistortion[v]);
        view_images[v].image = frame.images[v];
      }
      const std::vector<Pose> truth = {frame.femur, frame.tibia};
      std::vector<Pose> start;
      for (std::size_t b = 0; b < truth.size(); ++b) {
        start.push_back(perturbation.crude
                            ? perturbCrude(truth[b], camera_from_fixed, &rng, b == 1)
                            : perturb(truth[b], camera_from_fixed, &rng, perturbation.in_plane_mm,
                                      perturbation.out_of_plane_mm, perturbation.rotation_deg));
      }
      const imaging::EdgeMap map(frame.images[0], simulator.views()[0].camera, edge_settings);
      const std::vector<const geometry::Mesh*> meshes = {&implants.femoral_component,
                                                         &implants.tibial_tray};
      const double similarity_truth = imaging::projectionSimilarity(map, meshes, truth).total();
      for (std::size_t c = 0; c < conditions.size(); ++c) {
        Tally& tally = tallies[c];
        const auto t0 = std::chrono::steady_clock::now();
        registration::RegistrationResult result;
        if (perturbation.search) {
          try {
            result = searches[c]->search(view_images).registration;
          } catch (const InputError& e) {
            // Nothing found: a failed frame, which the search itself reported.
            std::cerr << "benchmark: trial " << trial << " frame " << f << ": " << e.what() << "\n";
            tally.add(
                {PoseError{Eigen::Vector3d::Constant(1e3), Eigen::Vector3d::Zero()}},
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                    .count(),
                0);
            tally.addStatus({"lost"}, false, {});
            continue;
          }
        } else {
          result = registrars[c]->solve(view_images, start);
        }
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        std::vector<PoseError> errors;
        for (std::size_t b = 0; b < truth.size(); ++b) {
          errors.push_back(poseError(result.poses[b], truth[b], camera_from_fixed));
        }
        tally.add(errors, ms, result.cost_evaluations);
        tally.addUncertainty(result, errors);
        const Eigen::Vector3d relative_result =
            result.poses[1].translation() - result.poses[0].translation();
        const Eigen::Vector3d relative_truth = truth[1].translation() - truth[0].translation();
        tally.addRelative(1e3 * (camera_from_fixed.linear() * (relative_result - relative_truth)));
        const constraints::ContactFigures figures =
            penetration_probe.figures(result.poses[0], result.poses[1]);
        if (figures.max_depth_m > 0.5e-3) ++tally.deep_penetrations;
        const bool success = tally.succeeded(errors);
        const kinematics::KneeCoordinates knee =
            kinematics::kneeCoordinates(result.poses[0], result.poses[1], s.side);
        const kinematics::KneeCoordinates true_knee =
            kinematics::kneeCoordinates(truth[0], truth[1], s.side);
        if (success) tally.addJoint(knee, true_knee);
        tally.addSimilarity(imaging::projectionSimilarity(map, meshes, result.poses).total(),
                            similarity_truth, success);
        std::vector<std::string> status = registration::classifyBones(result, settings.quality);
        inlier_histories[c].classify(result.quality, &status);
        tally.addStatus(status, success, errors);
        if (!success && !outputs.failure_overlay_dir.empty()) {
          char name[64];
          std::snprintf(name, sizeof(name), "/failed_c%zu_t%02d_f%03d.png", c, trial, f);
          std::vector<const imaging::SilhouetteModel*> models;
          for (const auto& bone : registrars[c]->bones()) models.push_back(bone.silhouette.get());
          cv::imwrite(outputs.failure_overlay_dir + name,
                      imaging::drawContourOverlay(frame.images[0], simulator.views()[0].camera,
                                                  models, result.poses));
        }
        if (quality_csv != nullptr) {
          for (std::size_t b = 0; b < truth.size(); ++b) {
            const auto& q = result.quality[b];
            const auto joint = result.joints.empty() ? registration::JointQuality()
                                                     : result.joints.front().quality;
            *quality_csv
                << c << "," << trial << "," << f << "," << b << ","
                << (registration::meetsSuccessCriterion(errors[b], tally.criterion) ? 1 : 0) << ","
                << (success ? 1 : 0) << "," << q.contour_inlier_fraction << "," << q.contour_rms_px
                << "," << 1e3 * figures.max_depth_m << "," << joint.envelope_violation << ","
                << (q.out_of_plane_sd_m >= 0.0 ? 1e3 * q.out_of_plane_sd_m : -1.0) << ","
                << (q.max_rotation_sd_rad >= 0.0 ? geometry::radToDeg(q.max_rotation_sd_rad) : -1.0)
                << "," << status[b];
            for (int i = 0; i < 3; ++i) *quality_csv << "," << errors[b].translation_mm[i];
            for (int i = 0; i < 3; ++i) *quality_csv << "," << errors[b].rotation_deg[i];
            for (const auto* k : {&knee, &true_knee}) {
              *quality_csv << "," << geometry::radToDeg(k->flexion_rad) << ","
                           << geometry::radToDeg(k->adduction_rad) << ","
                           << geometry::radToDeg(k->internal_rotation_rad);
            }
            const double* offset = firstViewEdgeOffset(result, b);
            *quality_csv << "," << (offset != nullptr ? *offset : 0.0) << "," << q.contour_spread_px
                         << "," << q.offset_inlier_fraction << "\n";
          }
        }
      }
    }
  }
  for (std::size_t c = 0; c < conditions.size(); ++c) {
    const std::string start =
        perturbation.search
            ? "no initial guess (automatic initialisation), success within 1 mm, 2/3 deg"
        : perturbation.crude
            ? "crude starts (femur +-3 mm in-plane, +-20 mm out-of-plane, +-5 deg; tibia +-3 mm, "
              "+-50 mm, +-5 deg in-plane, +-10 deg out-of-plane), success within 1.5 mm, 3/5 deg"
            : "start +-2 mm in-plane, +-3 mm out-of-plane, +-3 deg";
    const std::string implants =
        std::string(base.side == kinematics::Side::kLeft ? " (left knee)" : "") +
        (base.implant_meshes.any() ? " (implant models from files)" : "") +
        (base.implants.posteriorStabilised() ? " (posterior-stabilised)" : "");
    tallies[c].print("simulated " + std::string(views == 1 ? "single-plane" : "bi-plane") +
                     " total knee" + implants + ", " + std::to_string(trials) + " trial(s) x " +
                     std::to_string(frames) + " frame(s), " + trial_set + " images, " +
                     conditions[c].name + ", " + start + ":");
  }
}

// The Kneel knee's ligament envelope. Its rotation bounds hold whatever the meshes' origins;
// flexion is left free (these meshes' medial-lateral axes point the other way, so flexion comes
// out negative), and there is no insert for contact.
registration::JointModel kneelKnee(const constraints::LigamentSettings& ligaments) {
  registration::JointModel knee;
  knee.name = "knee";
  knee.parent = 0;
  knee.child = 1;
  knee.ligaments = ligaments;
  knee.ligaments.enabled = true;
  knee.ligaments.bounds[0] = {-180.0, 180.0};
  return knee;
}

void runKneel(const std::string& dir, int starts, std::uint64_t seed,
              const registration::RegistrationSettings& settings, bool search,
              const registration::PoseSearchSettings& search_settings,
              const std::vector<Condition>& conditions,
              const constraints::LigamentSettings& ligaments) {
  const auto calibration = io::readJointTrackCalibration(dir + "/calibration.txt");
  const geometry::Mesh femur = geometry::Mesh::load(dir + "/KR_right_7_fem.stl");
  const geometry::Mesh tibia = geometry::Mesh::load(dir + "/KR_right_6_tib.stl");
  const auto femur_poses = io::readJtsFile(dir + "/fem.jts");
  const auto tibia_poses = io::readJtsFile(dir + "/tib.jts");
  const std::vector<registration::BoneModel> bones =
      boneModels({&femur, &tibia}, {"femur", "tibia"});
  // The three real frames, each with its camera and the lab's reference poses.
  struct KneelFrame {
    std::string name;
    cv::Mat image;
    geometry::XrayCamera camera;
    std::vector<Pose> reference;
  };
  std::vector<KneelFrame> frames;
  for (const std::string name : {"0160", "0170", "0180"}) {
    const std::size_t f = frames.size();
    KneelFrame frame;
    frame.name = name;
    frame.image = cv::imread(dir + "/AT_K1_V1_" + name + ".tif", cv::IMREAD_UNCHANGED);
    if (frame.image.empty()) throw InputError("cannot read Kneel frame " + name);
    frame.camera = io::cameraFromJointTrack(calibration, frame.image.cols, frame.image.rows);
    frame.reference = {io::opticalFromJointTrack(*femur_poses[f]),
                       io::opticalFromJointTrack(*tibia_poses[f])};
    frames.push_back(frame);
  }
  if (search) {
    // No guess: automatic initialisation on each frame. The knee's envelope resolves mirror
    // hypotheses.
    const auto search_registrar = std::make_shared<const registration::Registrar>(
        bones, settings,
        std::vector<registration::JointModel>{kneelKnee(constraints::LigamentSettings())});
    const registration::PoseSearch pose_search(search_registrar, search_settings);
    std::cout << "real JointTrack Kneel frames, automatic initialisation (no guess):\n";
    int within = 0;
    for (const KneelFrame& frame : frames) {
      std::cout << "  frame " << frame.name << ":";
      bool ok = true;
      try {
        const auto found = pose_search.search({{frame.image, frame.camera}});
        for (std::size_t b = 0; b < 2; ++b) {
          const PoseError e =
              poseError(found.registration.poses[b], frame.reference[b], Pose::Identity());
          const double in_plane = std::hypot(e.translation_mm.x(), e.translation_mm.y());
          std::cout << std::fixed << std::setprecision(2) << (b == 0 ? " femur" : "  tibia")
                    << " in-plane " << in_plane << " mm, out-of-plane " << e.translation_mm.z()
                    << " mm, rotation " << e.rotation_deg.norm() << " deg (" << found.status[b]
                    << ");";
          ok = ok && in_plane <= 2.0 && e.rotation_deg.norm() <= 3.0;
        }
        std::cout << " " << found.regions << " regions, " << found.seconds << " s\n";
      } catch (const InputError& e) {
        std::cout << " not found: " << e.what() << "\n";
        ok = false;
      }
      within += ok ? 1 : 0;
    }
    std::cout << "  within 2 mm in-plane and 3 deg of the reference: " << within << "/"
              << frames.size() << "\n";
    return;
  }
  for (const Condition& condition : conditions) {
    if (condition.contact) {
      std::cout << "real JointTrack Kneel frames, " << condition.name
                << ": skipped (the Kneel data has no tibial insert mesh for contact)\n";
      continue;
    }
    std::vector<registration::JointModel> joints;
    if (condition.ligaments) joints.push_back(kneelKnee(ligaments));
    const registration::Registrar condition_registrar(bones, settings, joints);
    // The same starts for every condition.
    std::mt19937_64 rng(seed);
    std::cout << "real JointTrack Kneel frames, " << condition.name << ", " << starts
              << " perturbed start(s) per frame (+-2 mm in-plane, +-3 mm out-of-plane, +-3 deg):\n";
    int within = 0;
    int total = 0;
    for (const KneelFrame& frame : frames) {
      for (int s = 0; s < starts; ++s) {
        std::vector<Pose> start;
        for (const Pose& r : frame.reference)
          start.push_back(perturb(r, Pose::Identity(), &rng, 2.0, 3.0, 3.0));
        const auto result = condition_registrar.solve({{frame.image, frame.camera}}, start);
        std::cout << "  frame " << frame.name << " start " << s << ":";
        bool ok = true;
        for (std::size_t b = 0; b < 2; ++b) {
          const PoseError e = poseError(result.poses[b], frame.reference[b], Pose::Identity());
          const double in_plane = std::hypot(e.translation_mm.x(), e.translation_mm.y());
          std::cout << std::fixed << std::setprecision(2) << (b == 0 ? " femur" : "  tibia")
                    << " in-plane " << in_plane << " mm, out-of-plane " << e.translation_mm.z()
                    << " mm, rotation " << e.rotation_deg.norm() << " deg";
          if (const double* offset = firstViewEdgeOffset(result, b)) {
            std::cout << ", edge offset " << *offset << " px";
          }
          std::cout << ";";
          ok = ok && in_plane <= 1.0 && e.rotation_deg.norm() <= 2.0;
        }
        std::cout << "\n";
        within += ok ? 1 : 0;
        ++total;
      }
    }
    std::cout << "  within 1 mm in-plane and 2 deg of the reference: " << within << "/" << total
              << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  po::options_description options("benchmark: registration accuracy and speed\n\nOptions");
  int trials = 4;
  int frames = 25;
  int views = 1;
  int kneel_starts = 5;
  std::uint64_t seed = 7;
  std::string kneel_dir;
  Perturbation perturbation;
  registration::RegistrationSettings settings;
  std::vector<double> scales;
  std::string depth_retry_shifts;
  std::string rescue_depth_factors;
  std::string edge_match_depth_factors;
  std::string edge_match_nearer_depth_factors;
  std::string conditions_option = "image,contact";
  std::string edge_offset_model = "uniform";
  std::string parameterisation = "absolute";
  std::string protocol = "standard";
  std::string trial_set = "good";
  std::string simulator_config;
  constraints::LigamentSettings ligaments;
  std::string contact_measure = "quasi_volume";
  std::string quality_csv_path;
  std::string failure_overlay_dir;
  constraints::ContactSettings contact;
  options.add_options()("help,h", "show this help")(
      "trials", po::value(&trials)->default_value(trials), "simulated trials")(
      "frames", po::value(&frames)->default_value(frames), "frames per trial")(
      "views", po::value(&views)->default_value(views), "1 (single plane) or 2 (bi-plane)")(
      "seed", po::value(&seed)->default_value(seed), "random seed")(
      "kneel", po::value(&kneel_dir),
      "JointTrack Kneel folder (e.g. ../shared/data/jointtrack_kneel)")(
      "kneel-starts", po::value(&kneel_starts)->default_value(kneel_starts),
      "perturbed starts per Kneel frame")("skip-simulated", "only run the real-image check")(
      "in-plane-mm", po::value(&perturbation.in_plane_mm)->default_value(2.0),
      "start perturbation")("out-of-plane-mm",
                            po::value(&perturbation.out_of_plane_mm)->default_value(3.0),
                            "start perturbation")(
      "rotation-deg", po::value(&perturbation.rotation_deg)->default_value(3.0),
      "start perturbation")("scales", po::value(&scales)->multitoken(),
                            "coarse-to-fine image scales (default 0.5 1)")(
      "outer-iterations",
      po::value(&settings.outer_iterations)->default_value(settings.outer_iterations),
      "silhouette re-extractions per scale")(
      "coarse-outer-iterations",
      po::value(&settings.coarse_outer_iterations)->default_value(settings.coarse_outer_iterations),
      "outer iterations at each scale coarser than the finest (0: as --outer-iterations)")(
      "solver-iterations",
      po::value(&settings.solver_iterations)->default_value(settings.solver_iterations),
      "Levenberg-Marquardt iterations per outer iteration")(
      "robust-px", po::value(&settings.robust_scale_px)->default_value(settings.robust_scale_px),
      "Cauchy scale of the contour distance, full-resolution pixels")(
      "robust-final-px",
      po::value(&settings.robust_scale_final_px)->default_value(settings.robust_scale_final_px),
      "... from the finest scale's second outer iteration on (<= 0: --robust-px throughout)")(
      "inner-edge-margin-px",
      po::value(&settings.inner_edge_margin_px)->default_value(settings.inner_edge_margin_px),
      "from the finest scale's second outer iteration on, leave out the edges this far inside "
      "each bone's own silhouette (0: off)")(
      "mirror-check",
      po::value(&settings.mirror_check.enabled)->default_value(settings.mirror_check.enabled),
      "single view: also solve from the tibial tray's mirror pose and keep it if it fits as well "
      "and the knee is nearer neutral (true/false)")(
      "reflection-retry",
      po::value(&settings.reflection_retry.enabled)
          ->default_value(settings.reflection_retry.enabled),
      "single view: a bone whose contour inlier fraction is below --reflection-retry-below-inliers "
      "is solved again from its reflections across the beam; of those that gain "
      "--reflection-retry-min-gain inliers at a lower cost, the one ending nearest its start is "
      "kept (true/false)")("reflection-retry-below-inliers",
                           po::value(&settings.reflection_retry.below_inlier_fraction)
                               ->default_value(settings.reflection_retry.below_inlier_fraction),
                           "the reflection retry's gate")(
      "reflection-retry-min-gain",
      po::value(&settings.reflection_retry.min_inlier_gain)
          ->default_value(settings.reflection_retry.min_inlier_gain),
      "the inlier fraction a reflection must gain to be kept")(
      "reflection-retry-before-mirror-check",
      po::value(&settings.reflection_retry.before_mirror_check)
          ->default_value(settings.reflection_retry.before_mirror_check),
      "... also a bone the mirror check does not reflect (the femur) that the first solution, "
      "before the check replaced it, left below the gate (true/false)")(
      "rotation-retry",
      po::value(&settings.rotation_retry.enabled)->default_value(settings.rotation_retry.enabled),
      "a bone whose contour spread is above --rotation-retry-above-spread-px is solved again "
      "from the result turned --rotation-retry-step-deg either way about each of its axes; the "
      "lowest cost, if lower, is kept (true/false)")(
      "rotation-retry-above-spread-px",
      po::value(&settings.rotation_retry.above_contour_spread_px)
          ->default_value(settings.rotation_retry.above_contour_spread_px),
      "the rotation retry's gate")(
      "rotation-retry-step-deg",
      po::value(&settings.rotation_retry.step_deg)->default_value(settings.rotation_retry.step_deg),
      "the rotation retry's turn")(
      "depth-retry",
      po::value(&settings.depth_retry.enabled)->default_value(settings.depth_retry.enabled),
      "when a bone's status is not ok, solve again from the starts moved along the beam by "
      "each of --depth-retry-shifts-mm and keep the best (true/false)")(
      "depth-retry-shifts-mm", po::value(&depth_retry_shifts),
      "the depth retry's shifts along the beam, comma-separated mm (default -15,15)")(
      "depth-retry-light-below-inliers",
      po::value(&settings.depth_retry.light_below_inlier_fraction)
          ->default_value(settings.depth_retry.light_below_inlier_fraction),
      "every bone ok but one below this contour inlier fraction: solve again from the same "
      "shifts on the finest scale's maps only (0: never)")(
      "depth-retry-other-views-shift-mm",
      po::value(&settings.depth_retry.other_views_shift_mm)
          ->default_value(settings.depth_retry.other_views_shift_mm),
      "two or more views: first move each bone in doubt by its own contour's shift to the views' "
      "edges, up to this far (0: off)")(
      "contour-spacing-px",
      po::value(&settings.contour_spacing_px)->default_value(settings.contour_spacing_px),
      "silhouette contour sample spacing, pixels at each scale")(
      "min-edge-significance",
      po::value(&settings.edges.min_edge_significance)
          ->default_value(settings.edges.min_edge_significance),
      "edges: keep chains whose gradient reaches this many local noise standard deviations "
      "(0: off)")(
      "clipped-grey-margin",
      po::value(&settings.edges.clipped_grey_margin)
          ->default_value(settings.edges.clipped_grey_margin),
      "edges: leave out outline beside grey clipped by the display window, to within this "
      "fraction of the edge map's grey window (0: off)")(
      "skip-saturated-borders",
      po::value(&settings.edges.thresholds_skip_saturated_borders)
          ->default_value(settings.edges.thresholds_skip_saturated_borders),
      "edges: the automatic thresholds leave out large saturated areas reaching the region's "
      "border (a collimator, open air) (true/false)")(
      "mirror-turn",
      po::value(&settings.mirror_check.turn_reflection)
          ->default_value(settings.mirror_check.turn_reflection),
      "the mirror check also tries the tray's turn about its long axis reflected (true/false)")(
      "mirror-tilt",
      po::value(&settings.mirror_check.tilt_reflection)
          ->default_value(settings.mirror_check.tilt_reflection),
      "... and its tilt alone reflected, its turn kept (true/false)")(
      "mirror-cost-tolerance",
      po::value(&settings.mirror_check.cost_tolerance)
          ->default_value(settings.mirror_check.cost_tolerance),
      "the mirror solution is kept only if its final cost is within this fraction of the first")(
      "mirror-min-neutral-gain",
      po::value(&settings.mirror_check.min_neutral_gain)
          ->default_value(settings.mirror_check.min_neutral_gain),
      "... and its joint is nearer neutral by more than this (units of the ligament bounds)")(
      "neutral-rotation-per-flexion",
      po::value(&settings.mirror_check.neutral_internal_rotation_per_flexion)
          ->default_value(settings.mirror_check.neutral_internal_rotation_per_flexion),
      "the knee's neutral internal rotation per degree of flexion, in that comparison and the "
      "automatic search's (0: neutral at 0 deg at any flexion)")(
      "mirror-outer-iterations",
      po::value(&settings.mirror_check.outer_iterations)
          ->default_value(settings.mirror_check.outer_iterations),
      "outer iterations of the mirror's solve")(
      "mirror-solver-iterations",
      po::value(&settings.mirror_check.solver_iterations)
          ->default_value(settings.mirror_check.solver_iterations),
      "Levenberg-Marquardt iterations per outer iteration of the mirror's solve")(
      "mirror-continued-outer-iterations",
      po::value(&settings.mirror_check.continued_outer_iterations)
          ->default_value(settings.mirror_check.continued_outer_iterations),
      "outer iterations more for a mirror still in the running after its own, not converged "
      "(0: none)")(
      "mirror-abandon-cost-ratio",
      po::value(&settings.mirror_check.abandon_cost_ratio)
          ->default_value(settings.mirror_check.abandon_cost_ratio),
      "a mirror's solve stops after an outer iteration (not its last) that leaves its cost above "
      "this times the first solution's (1e9: never)")(
      "mirror-abandon-deviation-excess",
      po::value(&settings.mirror_check.abandon_deviation_excess)
          ->default_value(settings.mirror_check.abandon_deviation_excess),
      "... or its joint farther from neutral than the deviation it must beat by more than this "
      "(units of the ligament bounds; 1e9: never)")(
      "mirror-start-deviation-excess",
      po::value(&settings.mirror_check.start_deviation_excess)
          ->default_value(settings.mirror_check.start_deviation_excess),
      "a mirror whose start is farther from neutral than the deviation it must beat by more than "
      "this is not solved (units of the ligament bounds; 1e9: never)")(
      "edge-blur-px",
      po::value(&settings.edges.blur_sigma_px)->default_value(settings.edges.blur_sigma_px),
      "edges: Gaussian smoothing before Canny, pixels of each map's scale")(
      "clahe", po::value(&settings.edges.clahe)->default_value(settings.edges.clahe),
      "contrast-limited adaptive equalisation of each edge map's grey levels (true/false)")(
      "clahe-clip-limit",
      po::value(&settings.edges.clahe_clip_limit)->default_value(settings.edges.clahe_clip_limit),
      "its contrast limit")(
      "reverse-weight",
      po::value(&settings.reverse_term_weight)->default_value(settings.reverse_term_weight),
      "weight of the edge-to-contour (reverse) term; 0: forward term only")(
      "edge-offset-model", po::value(&edge_offset_model)->default_value(edge_offset_model),
      "uniform (one offset per bone and view) or none")(
      "parameterisation", po::value(&parameterisation)->default_value(parameterisation),
      "absolute, or parent_relative (the tibia's increment relative to the femur's, the "
      "dissertation's Dataset B)")(
      "edge-offset-prior-px",
      po::value(&settings.edge_offset_prior_px)->default_value(settings.edge_offset_prior_px),
      "prior sigma of each bone's edge offset, pixels")(
      "edge-offset-min-px",
      po::value(&settings.edge_offset_min_px)->default_value(settings.edge_offset_min_px),
      "lowest edge offset a solve may end on, pixels (+ inward; -inf: no floor)")(
      "corner-rounding",
      po::value(&settings.corner_rounding)->default_value(settings.corner_rounding),
      "compare the contour near sharp turns where the edge map's smoothing puts the edges "
      "(true/false)")(
      "threads", po::value(&settings.threads)->default_value(settings.threads),
      "threads per registration: 2 or more build the finer scales' edge maps ahead and let the "
      "automatic search match and refine on that many (the same results as 1)")(
      "rendered-edges",
      po::value(&settings.rendered_edges.enabled)->default_value(settings.rendered_edges.enabled),
      "instead of corner rounding, compare the contour where the edge map finds the edges of "
      "each bone's own rendered radiograph (true/false)")(
      "rendered-edges-saturation-mm",
      po::value(&settings.rendered_edges.saturation_mm)
          ->default_value(settings.rendered_edges.saturation_mm),
      "metal path at which the rendered radiograph's grey saturates, mm")(
      "edge-offset-hold",
      po::value(&settings.edge_offset_hold)->default_value(settings.edge_offset_hold),
      "hold the edge offset at zero until the finest scale's second outer iteration "
      "(true/false)")(
      "staged",
      "the dissertation's Dataset B schedule: 2 outer iterations of image (femur weighted 2:1) "
      "and ligaments without contact, then 4 with every term")(
      "protocol", po::value(&protocol)->default_value(protocol),
      "standard (chapter 3: +-2 mm / +-3 mm / +-3 deg starts) or crude (chapter 4's crude guesses, "
      "coarse-to-fine scales 0.25 0.5 1 unless --scales is given) or search (no guess: "
      "automatic initialisation)")(
      "envelope-extra-refined",
      po::value(&perturbation.search_settings.envelope_extra_refined)
          ->default_value(perturbation.search_settings.envelope_extra_refined),
      "search: more of a bone's starts through its joint's envelope refined when none of its "
      "own fits (registration: search: envelope_extra_refined)")(
      "fine-envelope",
      po::value(&perturbation.search_settings.fine_envelope)
          ->default_value(perturbation.search_settings.fine_envelope),
      "search: a bone still unfound beside a well-found neighbour is searched again from it "
      "through a finer envelope (registration: search: fine_envelope; true/false)")(
      "rescue-depth-factors", po::value(&rescue_depth_factors),
      "search: a result with a bone not ok is solved again from its bones moved along their "
      "lines of sight to these fractions of their distance, comma-separated ('none': no "
      "rescue; registration: search: rescue_depth_factors)")(
      "edge-match-depth-factors", po::value(&edge_match_depth_factors),
      "search: chamfer matching at these fractions of the distance the image's regions suggest, "
      "comma-separated ('none': no chamfer matching; registration: search: "
      "edge_match_depth_factors)")(
      "edge-match-nearer-depth-factors", po::value(&edge_match_nearer_depth_factors),
      "search: ... and at these for a bone no hypothesis fits well after them, comma-separated "
      "('none': never; registration: search: edge_match_nearer_depth_factors)")(
      "edge-match-shape-regions",
      po::value(&perturbation.search_settings.edge_match_shape_regions)
          ->default_value(perturbation.search_settings.edge_match_shape_regions),
      "search: the partner-distance chamfer matching also around this many regions a bone's "
      "silhouettes match best (registration: search: edge_match_shape_regions)")(
      "edge-match-partner-depth-gap",
      po::value(&perturbation.search_settings.edge_match_partner_depth_gap)
          ->default_value(perturbation.search_settings.edge_match_partner_depth_gap),
      "search: a bone still unfound is matched at its joint partner's distance when its regions "
      "suggest one this fraction away (0: never; registration: search: "
      "edge_match_partner_depth_gap)")(
      "trial-set", po::value(&trial_set)->default_value(trial_set),
      "good (1024x1024) or poor (768x768, noisier, a metal rod across the tibia)")(
      "simulator-config", po::value(&simulator_config),
      "simulator settings YAML the trials start from (e.g. config/robustness/kneel_implants.yaml: "
      "other implant models); default: the simulator's defaults")(
      "ideal", "simulate without anatomy and noise (isolates the method from image clutter)")(
      "conditions", po::value(&conditions_option)->default_value(conditions_option),
      "comma-separated: image (image terms only), contact (image + articular contact), "
      "contact+separation, ligaments, contact+ligaments")(
      "contact-measure", po::value(&contact_measure)->default_value(contact_measure),
      "penetration_depth, penetration_area, quasi_volume, elastic_energy or separation")(
      "contact-weight", po::value(&contact.weight)->default_value(contact.weight),
      "weight of the contact residual")(
      "contact-exponent", po::value(&contact.exponent)->default_value(contact.exponent),
      "the residual is weight x measure^exponent")(
      "ligament-stiffness",
      po::value(&ligaments.stiffness_per_deg)->default_value(ligaments.stiffness_per_deg),
      "ligament springs: residual per degree (and per mm) outside the knee envelope")(
      "covariance", po::bool_switch(&settings.compute_covariance),
      "estimate each bone's covariance (for the quality status's standard-deviation tests)")(
      "covariance-offset-gradient-sd-px",
      po::value(&settings.covariance_offset_gradient_sd_px)
          ->default_value(settings.covariance_offset_gradient_sd_px),
      "the covariance's allowance for an unknown edge-offset gradient across each outline "
      "(full-resolution pixels, centre to end; 0: none)")(
      "inliers-at-edge-offset",
      po::value(&settings.quality.inliers_at_edge_offset)
          ->default_value(settings.quality.inliers_at_edge_offset),
      "status: the inlier tests count each contour sample where its bone's estimated edge "
      "offset puts it (true/false)")(
      "suspect-contour-rms-px",
      po::value(&settings.quality.suspect_contour_rms_px)
          ->default_value(settings.quality.suspect_contour_rms_px),
      "status: suspect above this RMS edge distance of a bone's contour inliers (pixels; 0: "
      "off)")(
      "suspect-contour-spread-px",
      po::value(&settings.quality.suspect_contour_spread_px)
          ->default_value(settings.quality.suspect_contour_spread_px),
      "status: suspect above this RMS of a bone's contour inliers' edge distances about their "
      "mean (pixels; 0: off)")(
      "suspect-out-of-plane-sd-mm",
      po::value(&settings.quality.suspect_out_of_plane_sd_mm)->default_value(0.0),
      "status: suspect above this out-of-plane standard deviation (needs --covariance)")(
      "suspect-rotation-sd-deg",
      po::value(&settings.quality.suspect_rotation_sd_deg)->default_value(0.0),
      "status: suspect above this rotational standard deviation (needs --covariance)")(
      "relative-inlier-drop",
      po::value(&settings.quality.relative_inlier_drop)
          ->default_value(settings.quality.relative_inlier_drop),
      "status: suspect this far below the median inlier fraction of the bone's earlier frames "
      "in the trial (0: off)")(
      "relative-inlier-spread",
      po::value(&settings.quality.relative_inlier_spread)
          ->default_value(settings.quality.relative_inlier_spread),
      "... or this many robust standard deviations of those frames' fractions, if more")(
      "relative-inlier-trend-frames",
      po::value(&settings.quality.relative_inlier_trend_frames)
          ->default_value(settings.quality.relative_inlier_trend_frames),
      "... and once there are this many, below the robust line through the last this many "
      "instead of the median (0: the median only)")(
      "unseen-edge-distance-px",
      po::value(&settings.quality.unseen_edge_distance_px)
          ->default_value(settings.quality.unseen_edge_distance_px),
      "status, two or more views: a view's contour samples farther than this from every edge "
      "are left out of the inlier fraction while the other views hold the bone (0: off)")(
      "quality-csv", po::value(&quality_csv_path),
      "write every registration's quality figures, status and errors (x, y in-plane and z along "
      "the beam in mm; rotations about the bone's axes in deg) and the knee's angles (result and "
      "truth) per bone to this CSV")(
      "failure-overlay-dir", po::value(&failure_overlay_dir),
      "write each failed simulated frame (first view) with the result's contours drawn, as "
      "failed_c<condition>_t<trial>_f<frame>.png, to this folder")(
      "contact-dead-band-mm", po::value(&contact.dead_band_mm)->default_value(contact.dead_band_mm),
      "penetration allowed without cost")(
      "contact-sample-spacing-mm",
      po::value(&contact.max_sample_spacing_mm)->default_value(contact.max_sample_spacing_mm),
      "largest spacing of the parent surface's contact samples (larger triangles are split; 0: "
      "vertices only)");
  po::variables_map vm;
  if (const auto exit_code = tools::parseCommandLine("benchmark", options, argc, argv, &vm)) {
    return *exit_code;
  }
  try {
    if (protocol == "search") {
      perturbation.search = true;
    } else if (protocol == "crude") {
      perturbation.crude = true;
      settings.scales = {0.25, 0.5, 1.0};
      settings.max_translation_from_start_m = 0.08;  // the tibia may start 50 mm off
    } else if (protocol != "standard") {
      throw InputError("--protocol must be standard, crude or search, not '" + protocol + "'");
    }
    if (!scales.empty()) settings.scales = scales;
    if (!depth_retry_shifts.empty()) {
      settings.depth_retry.shifts_mm =
          commaSeparatedNumbers(depth_retry_shifts, "--depth-retry-shifts-mm");
    }
    // A comma-separated list of factors or 'none' (an empty list); no text keeps the default.
    const auto read_factors = [](const std::string& text, const std::string& option,
                                 std::vector<double>* factors) {
      if (text == "none") {
        factors->clear();
      } else if (!text.empty()) {
        *factors = commaSeparatedNumbers(text, option);
      }
    };
    read_factors(rescue_depth_factors, "--rescue-depth-factors",
                 &perturbation.search_settings.rescue_depth_factors);
    read_factors(edge_match_depth_factors, "--edge-match-depth-factors",
                 &perturbation.search_settings.edge_match_depth_factors);
    read_factors(edge_match_nearer_depth_factors, "--edge-match-nearer-depth-factors",
                 &perturbation.search_settings.edge_match_nearer_depth_factors);
    perturbation.search_settings.validate();
    if (vm.count("staged")) {
      registration::RegistrationStage envelope;
      envelope.outer_iterations = 2;
      envelope.contact = false;
      envelope.image_weights = {{"femur", 2.0}, {"tibia", 1.0}};
      registration::RegistrationStage everything;
      everything.outer_iterations = settings.outer_iterations;
      settings.stages = {envelope, everything};
    }
    contact.measure = constraints::contactMeasureFromName(contact_measure);
    settings.edge_offset_model = registration::edgeOffsetModelFromName(edge_offset_model);
    settings.parameterisation = registration::parameterisationFromName(parameterisation);
    contact.validate();
    ligaments.stiffness_per_mm = ligaments.stiffness_per_deg;
    ligaments.validate();
    std::vector<Condition> conditions;
    std::stringstream list(conditions_option);
    for (std::string name; std::getline(list, name, ',');) {
      if (name == "image") {
        conditions.push_back({"image terms only", false});
      } else if (name == "contact") {
        conditions.push_back({"image + contact (" + contact_measure + ")", true});
      } else if (name == "contact+separation") {
        conditions.push_back(
            {"image + contact (" + contact_measure + ") + separation", true, true});
      } else if (name == "ligaments") {
        conditions.push_back({"image + ligaments", false, false, true});
      } else if (name == "contact+ligaments") {
        conditions.push_back(
            {"image + contact (" + contact_measure + ") + ligaments", true, false, true});
      } else {
        throw InputError("--conditions: unknown condition '" + name +
                         "' (image, contact, contact+separation, ligaments, contact+ligaments)");
      }
    }
    std::ofstream quality_csv;
    if (!quality_csv_path.empty()) {
      quality_csv.open(quality_csv_path);
      if (!quality_csv) throw InputError("cannot write --quality-csv '" + quality_csv_path + "'");
    }
    BenchmarkOutputs outputs;
    if (quality_csv.is_open()) outputs.quality_csv = &quality_csv;
    if (!failure_overlay_dir.empty()) {
      std::filesystem::create_directories(failure_overlay_dir);
      outputs.failure_overlay_dir = failure_overlay_dir;
    }
    if (!vm.count("skip-simulated")) {
      sim::TrialSimulatorSettings base;
      if (!simulator_config.empty()) base = sim::loadSimulatorSettings(simulator_config);
      runSimulated(base, trials, frames, views, seed, vm.count("ideal") > 0, trial_set,
                   perturbation, settings, conditions, contact, ligaments, outputs);
    }
    if (!kneel_dir.empty()) {
      runKneel(kneel_dir, kneel_starts, seed, settings, perturbation.search,
               perturbation.search_settings, conditions, ligaments);
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "benchmark: error: " << e.what() << "\n";
    return 1;
  }
}
