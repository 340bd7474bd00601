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
#include <iomanip>
#include <iostream>
#include <memory>
#include <random>
#include <sstream>

#include <boost/program_options.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fluoro_tracker/constraints/articular_contact.h"
#include "fluoro_tracker/imaging/projection_similarity.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/jointtrack_calibration.h"
#include "fluoro_tracker/io/jts_file.h"
#include "fluoro_tracker/registration/pose_error.h"
#include "fluoro_tracker/registration/registrar.h"
#include "fluoro_tracker/sim/trial_simulator.h"

namespace po = boost::program_options;
using namespace fluoro_tracker;
using geometry::Pose;

namespace {

using registration::PoseError;
using registration::poseError;

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

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * (v.size() - 1) + 0.5)];
}

struct Tally {
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

  void addSimilarity(double at_result, double at_truth, bool success) {
    similarity_result.push_back(at_result);
    similarity_truth.push_back(at_truth);
    if (!success && at_result < at_truth) ++failed_frames_scored_below_truth;
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
      if (std::abs(e.translation_mm.x()) > 1.0 || std::abs(e.translation_mm.y()) > 1.0)
        ++failures[b][0];
      if (std::abs(e.rotation_deg.x()) > 2.0) ++failures[b][1];
      if (std::abs(e.rotation_deg.y()) > 3.0) ++failures[b][2];
      if (std::abs(e.rotation_deg.z()) > 2.0) ++failures[b][3];
    }
    const bool ok = std::all_of(errors.begin(), errors.end(), registration::meetsSuccessCriterion);
    if (!ok) return;
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
    std::cout << std::setprecision(1) << "  time per frame: median "
              << percentile(milliseconds, 0.5) << " ms, p95 " << percentile(milliseconds, 0.95)
              << " ms; cost evaluations per frame: median " << percentile(evaluations, 0.5) << "\n";
  }
};

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
};

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
                                   const geometry::Mesh& insert,
                                   const constraints::ContactSettings& settings,
                                   const constraints::LigamentSettings& ligaments,
                                   const Condition& condition) {
  registration::JointModel knee;
  knee.name = "knee";
  knee.parent = 0;
  knee.child = 1;
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
                                                 const constraints::ContactSettings& settings,
                                                 const constraints::LigamentSettings& ligaments,
                                                 const Condition& condition) {
  if (!condition.contact && !condition.ligaments) return {};
  std::vector<registration::JointModel> joints = {
      kneeJoint(femoral_component, insert, settings, ligaments, condition)};
  if (condition.keep_in_contact) {
    constraints::ContactSettings separation = settings;
    separation.measure = constraints::ContactMeasure::kSeparation;
    separation.exponent = 1.0;
    separation.dead_band_mm = 0.0;
    Condition contact_only = condition;
    contact_only.ligaments = false;
    joints.push_back(kneeJoint(femoral_component, insert, separation, ligaments, contact_only));
  }
  return joints;
}

void runSimulated(int trials, int frames, int views, std::uint64_t seed, bool ideal_images,
                  const Perturbation& perturbation,
                  const registration::RegistrationSettings& settings,
                  const std::vector<Condition>& conditions,
                  const constraints::ContactSettings& contact_settings,
                  const constraints::LigamentSettings& ligament_settings) {
  std::vector<Tally> tallies(conditions.size());
  std::mt19937_64 rng(seed);
  for (int trial = 0; trial < trials; ++trial) {
    sim::TrialSimulatorSettings s;
    s.views = views;
    s.motion.frames = frames;
    s.seed = seed + trial;
    // Vary the trials: flexion range, view obliquity, polarity.
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    s.motion.max_flexion_deg = 60.0 + 60.0 * unit(rng);
    s.view_yaw_deg = -8.0 + 16.0 * unit(rng);
    s.view_roll_deg = -5.0 + 10.0 * unit(rng);
    s.detector.implants_bright = trial % 2 == 1;
    if (ideal_images) {
      s.anatomy = false;
      s.detector.photons_per_pixel = 0.0;
    }
    const sim::TrialSimulator simulator(s);
    const auto& implants = simulator.implants();
    std::vector<std::unique_ptr<registration::Registrar>> registrars;
    for (const Condition& condition : conditions) {
      registrars.push_back(std::make_unique<registration::Registrar>(
          boneModels({&implants.femoral_component, &implants.tibial_tray}, {"femur", "tibia"}),
          settings,
          kneeJoints(implants.femoral_component, implants.tibial_insert, contact_settings,
                     ligament_settings, condition)));
    }
    // Measures penetration at every result, with or without contact in the registration.
    const constraints::ArticularContact penetration_probe(implants.femoral_component,
                                                          implants.tibial_insert, contact_settings);
    std::vector<registration::ViewImage> view_images;
    for (const auto& v : simulator.views()) view_images.push_back({cv::Mat(), v.camera});
    const Pose camera_from_fixed = simulator.views()[0].camera.worldFromCamera().inverse();
    const imaging::EdgeMapSettings edge_settings = settings.edges;
    for (int f = 0; f < frames; ++f) {
      const sim::SimulatedFrame frame = simulator.render(f, &rng);
      for (std::size_t v = 0; v < view_images.size(); ++v) view_images[v].image = frame.images[v];
      const std::vector<Pose> truth = {frame.femur, frame.tibia};
      std::vector<Pose> start;
      for (const Pose& t : truth) {
        start.push_back(perturb(t, camera_from_fixed, &rng, perturbation.in_plane_mm,
                                perturbation.out_of_plane_mm, perturbation.rotation_deg));
      }
      const imaging::EdgeMap map(frame.images[0], simulator.views()[0].camera, edge_settings);
      const std::vector<const geometry::Mesh*> meshes = {&implants.femoral_component,
                                                         &implants.tibial_tray};
      const double similarity_truth = imaging::projectionSimilarity(map, meshes, truth).total();
      for (std::size_t c = 0; c < conditions.size(); ++c) {
        Tally& tally = tallies[c];
        const auto t0 = std::chrono::steady_clock::now();
        const auto result = registrars[c]->solve(view_images, start);
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        std::vector<PoseError> errors;
        for (std::size_t b = 0; b < truth.size(); ++b) {
          errors.push_back(poseError(result.poses[b], truth[b], camera_from_fixed));
        }
        tally.add(errors, ms, result.cost_evaluations);
        const Eigen::Vector3d relative_result =
            result.poses[1].translation() - result.poses[0].translation();
        const Eigen::Vector3d relative_truth = truth[1].translation() - truth[0].translation();
        tally.addRelative(1e3 * (camera_from_fixed.linear() * (relative_result - relative_truth)));
        const constraints::ContactFigures figures =
            penetration_probe.figures(result.poses[0], result.poses[1]);
        if (figures.max_depth_m > 0.5e-3) ++tally.deep_penetrations;
        tally.addSimilarity(
            imaging::projectionSimilarity(map, meshes, result.poses).total(), similarity_truth,
            std::all_of(errors.begin(), errors.end(), registration::meetsSuccessCriterion));
      }
    }
  }
  for (std::size_t c = 0; c < conditions.size(); ++c) {
    tallies[c].print("simulated " + std::string(views == 1 ? "single-plane" : "bi-plane") +
                     " total knee, " + std::to_string(trials) + " trial(s) x " +
                     std::to_string(frames) + " frame(s), 1024x1024, " + conditions[c].name +
                     ", start +-2 mm in-plane, +-3 mm out-of-plane, +-3 deg:");
  }
}

void runKneel(const std::string& dir, int starts, std::uint64_t seed,
              const registration::RegistrationSettings& settings) {
  const auto calibration = io::readJointTrackCalibration(dir + "/calibration.txt");
  const geometry::Mesh femur = geometry::Mesh::load(dir + "/KR_right_7_fem.stl");
  const geometry::Mesh tibia = geometry::Mesh::load(dir + "/KR_right_6_tib.stl");
  const auto femur_poses = io::readJtsFile(dir + "/fem.jts");
  const auto tibia_poses = io::readJtsFile(dir + "/tib.jts");
  const registration::Registrar registrar(boneModels({&femur, &tibia}, {"femur", "tibia"}),
                                          settings);
  const std::vector<std::string> frames = {"0160", "0170", "0180"};
  std::mt19937_64 rng(seed);
  std::cout << "real JointTrack Kneel frames, " << starts
            << " perturbed start(s) per frame (+-2 mm in-plane, +-3 mm out-of-plane, +-3 deg):\n";
  int within = 0;
  int total = 0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const cv::Mat image = cv::imread(dir + "/AT_K1_V1_" + frames[f] + ".tif", cv::IMREAD_UNCHANGED);
    if (image.empty()) throw InputError("cannot read Kneel frame " + frames[f]);
    const geometry::XrayCamera camera =
        io::cameraFromJointTrack(calibration, image.cols, image.rows);
    const std::vector<Pose> reference = {io::opticalFromJointTrack(*femur_poses[f]),
                                         io::opticalFromJointTrack(*tibia_poses[f])};
    for (int s = 0; s < starts; ++s) {
      std::vector<Pose> start;
      for (const Pose& r : reference)
        start.push_back(perturb(r, Pose::Identity(), &rng, 2.0, 3.0, 3.0));
      const auto result = registrar.solve({{image, camera}}, start);
      std::cout << "  frame " << frames[f] << " start " << s << ":";
      bool ok = true;
      for (std::size_t b = 0; b < 2; ++b) {
        const PoseError e = poseError(result.poses[b], reference[b], Pose::Identity());
        const double in_plane = std::hypot(e.translation_mm.x(), e.translation_mm.y());
        std::cout << std::fixed << std::setprecision(2) << (b == 0 ? " femur" : "  tibia")
                  << " in-plane " << in_plane << " mm, out-of-plane " << e.translation_mm.z()
                  << " mm, rotation " << e.rotation_deg.norm() << " deg;";
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
  std::string conditions_option = "image,contact";
  std::string edge_offset_model = "uniform";
  constraints::LigamentSettings ligaments;
  std::string contact_measure = "quasi_volume";
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
                            "coarse-to-fine image scales, e.g. 0.5 1 (default 1)")(
      "outer-iterations",
      po::value(&settings.outer_iterations)->default_value(settings.outer_iterations),
      "silhouette re-extractions per scale")(
      "solver-iterations",
      po::value(&settings.solver_iterations)->default_value(settings.solver_iterations),
      "Levenberg-Marquardt iterations per outer iteration")(
      "robust-px", po::value(&settings.robust_scale_px)->default_value(settings.robust_scale_px),
      "Cauchy scale of the contour distance, full-resolution pixels")(
      "reverse-weight",
      po::value(&settings.reverse_term_weight)->default_value(settings.reverse_term_weight),
      "weight of the edge-to-contour (reverse) term; 0: forward term only")(
      "edge-offset-model", po::value(&edge_offset_model)->default_value(edge_offset_model),
      "uniform (one offset per bone and view) or none")(
      "edge-offset-prior-px",
      po::value(&settings.edge_offset_prior_px)->default_value(settings.edge_offset_prior_px),
      "prior sigma of each bone's edge offset, pixels")(
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
      "contact-dead-band-mm", po::value(&contact.dead_band_mm)->default_value(contact.dead_band_mm),
      "penetration allowed without cost");
  po::variables_map vm;
  try {
    po::store(po::parse_command_line(argc, argv, options), vm);
    po::notify(vm);
  } catch (const po::error& e) {
    std::cerr << "benchmark: " << e.what() << "\n" << options << "\n";
    return 2;
  }
  if (vm.count("help")) {
    std::cout << options << "\n";
    return 0;
  }
  try {
    if (!scales.empty()) settings.scales = scales;
    contact.measure = constraints::contactMeasureFromName(contact_measure);
    settings.edge_offset_model = registration::edgeOffsetModelFromName(edge_offset_model);
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
    if (!vm.count("skip-simulated")) {
      runSimulated(trials, frames, views, seed, vm.count("ideal") > 0, perturbation, settings,
                   conditions, contact, ligaments);
    }
    if (!kneel_dir.empty()) runKneel(kneel_dir, kneel_starts, seed, settings);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "benchmark: error: " << e.what() << "\n";
    return 1;
  }
}
