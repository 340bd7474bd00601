#include "fluoro_tracker/io/trial_config.h"

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include <yaml-cpp/yaml.h>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/yaml_file.h"
#include "fluoro_tracker/kinematics/joint_types.h"

namespace fluoro_tracker {
namespace io {
namespace {

namespace fs = std::filesystem;

void writePose(YAML::Emitter* out, const std::string& key, const geometry::Pose& pose) {
  const Eigen::Vector3d t = pose.translation();
  const Eigen::Quaterniond q(pose.linear());
  *out << YAML::Key << key << YAML::Value << YAML::BeginMap;
  *out << YAML::Key << "position_m" << YAML::Value << YAML::Flow
       << std::vector<double>{t.x(), t.y(), t.z()};
  *out << YAML::Key << "orientation_xyzw" << YAML::Value << YAML::Flow
       << std::vector<double>{q.x(), q.y(), q.z(), q.w()};
  *out << YAML::EndMap;
}

// A joint's `contact:` section; absent: contact disabled.
constraints::ContactSettings readContactSettings(const YAML::Node& joint,
                                                 const std::string& context) {
  constraints::ContactSettings c;
  const YAML::Node node = joint["contact"];
  if (!node) {
    c.enabled = false;
    return c;
  }
  const YamlSection section(node, context + ".contact");
  section.allowOnly({"enabled", "measure", "dead_band_mm", "exponent", "weight", "loaded_weight",
                     "region", "max_sample_spacing_mm", "grid_spacing_mm", "grid_margin_mm",
                     "grid_exact_band_mm"});
  section.read("enabled", &c.enabled);
  std::string measure = constraints::contactMeasureName(c.measure);
  section.read("measure", &measure);
  section.read("dead_band_mm", &c.dead_band_mm);
  section.read("exponent", &c.exponent);
  section.read("weight", &c.weight);
  section.read("loaded_weight", &c.loaded_weight);
  section.read("max_sample_spacing_mm", &c.max_sample_spacing_mm);
  double spacing_mm = c.grid.spacing_m * 1e3;
  double margin_mm = c.grid.margin_m * 1e3;
  double band_mm = c.grid.exact_band_m * 1e3;
  section.read("grid_spacing_mm", &spacing_mm);
  section.read("grid_margin_mm", &margin_mm);
  section.read("grid_exact_band_mm", &band_mm);
  c.grid.spacing_m = spacing_mm * 1e-3;
  c.grid.margin_m = margin_mm * 1e-3;
  c.grid.exact_band_m = band_mm * 1e-3;
  const YamlSection region = section.child("region");
  region.allowOnly({"box_min_mm", "box_max_mm", "normal", "max_angle_deg"});
  std::vector<double> box_min;
  std::vector<double> box_max;
  std::vector<double> normal;
  region.read("box_min_mm", &box_min);
  region.read("box_max_mm", &box_max);
  region.read("normal", &normal);
  region.read("max_angle_deg", &c.region.max_angle_deg);
  if (box_min.size() != box_max.size() || (box_min.size() != 0 && box_min.size() != 3)) {
    throw InputError(context + ".contact.region: box_min_mm and box_max_mm need 3 numbers each");
  }
  if (box_min.size() == 3) {
    c.region.box = Eigen::AlignedBox3d(1e-3 * Eigen::Vector3d(box_min[0], box_min[1], box_min[2]),
                                       1e-3 * Eigen::Vector3d(box_max[0], box_max[1], box_max[2]));
  }
  if (!normal.empty()) {
    if (normal.size() != 3) throw InputError(context + ".contact.region: normal needs 3 numbers");
    c.region.normal = Eigen::Vector3d(normal[0], normal[1], normal[2]);
  }
  try {
    c.measure = constraints::contactMeasureFromName(measure);
    c.validate();
  } catch (const InputError& e) {
    throw InputError(context + ": " + e.what());
  }
  return c;
}

// The `ligaments:` keys of a joint type's six coordinates: its angles in degrees, then x, y, z
// in millimetres (the knee's: flexion_deg, adduction_deg, internal_rotation_deg, x_mm, ...).
std::array<std::string, 6> ligamentKeys(kinematics::JointType type) {
  const auto& angles = kinematics::coordinateNames(type).angles;
  const auto& knee = constraints::LigamentSettings::coordinateNames();
  return {angles[0] + "_deg", angles[1] + "_deg", angles[2] + "_deg", knee[3], knee[4], knee[5]};
}

// Bounds on the type's first angle <-> on the knee's flexion, which the springs act on.
constraints::CoordinateBounds firstAngleBounds(kinematics::JointType type,
                                               const constraints::CoordinateBounds& bounds) {
  // A glenohumeral joint's springs act on its own Euler angles (glenohumeral_springs.h).
  if (!kinematics::hasKneeFrameCoordinates(type) || kinematics::firstAngleSign(type) > 0.0) {
    return bounds;
  }
  return {-bounds.upper, -bounds.lower};
}

// A joint's `ligaments:` section, in the joint type's coordinates; absent: springs disabled.
// A knee's unlisted bounds are the dissertation's defaults, another type's are free.
constraints::LigamentSettings readLigamentSettings(const YAML::Node& joint,
                                                   const std::string& context,
                                                   kinematics::JointType type) {
  constraints::LigamentSettings l;
  // The dissertation's defaults are a knee's; other types' bounds are free unless listed (the
  // automatic search's envelope reads them with the springs off too).
  if (type != kinematics::JointType::kKnee) l.bounds = {};
  const YAML::Node node = joint["ligaments"];
  if (!node) {
    l.enabled = false;
    return l;
  }
  const YamlSection section(node, context + ".ligaments");
  const auto names = ligamentKeys(type);
  section.allowOnly({"enabled", names[0].c_str(), names[1].c_str(), names[2].c_str(),
                     names[3].c_str(), names[4].c_str(), names[5].c_str(), "stiffness_per_deg",
                     "stiffness_per_mm", "bundles"});
  section.read("enabled", &l.enabled);
  for (int k = 0; k < 6; ++k) {
    std::vector<double> bounds;
    section.read(names[k], &bounds);
    if (bounds.empty()) continue;
    if (bounds.size() != 2) {
      throw InputError(context + ".ligaments." + names[k] +
                       " needs [lower, upper] (.inf or -.inf for none)");
    }
    l.bounds[k] = {bounds[0], bounds[1]};
    if (k == 0) l.bounds[k] = firstAngleBounds(type, l.bounds[k]);
  }
  section.read("stiffness_per_deg", &l.stiffness_per_deg);
  section.read("stiffness_per_mm", &l.stiffness_per_mm);
  const YAML::Node bundles = node["bundles"];
  if (bundles && !bundles.IsSequence()) {
    throw InputError(context + ".ligaments.bundles must be a list");
  }
  for (std::size_t i = 0; bundles && i < bundles.size(); ++i) {
    const std::string where = context + ".ligaments.bundles[" + std::to_string(i) + "]";
    const YamlSection b(bundles[i], where);
    b.allowOnly({"name", "parent_insertion_mm", "child_insertion_mm", "slack_length_mm",
                 "stiffness_per_mm"});
    constraints::LigamentBundle bundle;
    b.read("name", &bundle.name);
    const auto point_m = [&](const char* key) -> Eigen::Vector3d {
      std::vector<double> mm;
      b.read(key, &mm);
      if (mm.size() != 3) throw InputError(where + "." + key + " needs [x, y, z] in mm");
      return Eigen::Vector3d(mm[0], mm[1], mm[2]) * 1e-3;
    };
    bundle.parent_insertion_m = point_m("parent_insertion_mm");
    bundle.child_insertion_m = point_m("child_insertion_mm");
    double slack_mm = 0.0;
    b.read("slack_length_mm", &slack_mm);
    bundle.slack_length_m = slack_mm * 1e-3;
    b.read("stiffness_per_mm", &bundle.stiffness_per_mm);
    l.bundles.push_back(bundle);
  }
  try {
    l.validate();
  } catch (const InputError& e) {
    throw InputError(context + ": " + e.what());
  }
  return l;
}

// The `registration: search:` subsection: automatic initialisation and recovery.
registration::PoseSearchSettings readSearchSettings(const YAML::Node& node,
                                                    const std::string& context) {
  registration::PoseSearchSettings s;
  const YamlSection section(node, context);
  section.allowOnly({"direction_step_deg",
                     "roll_step_deg",
                     "matches_per_bone",
                     "screening_scale",
                     "refined_per_bone",
                     "wide_screening_px",
                     "wide_refined_per_bone",
                     "envelope_extra_refined",
                     "fine_envelope",
                     "fine_envelope_flexion_step_deg",
                     "fine_envelope_anterior_step_mm",
                     "fine_envelope_neighbour_inliers",
                     "mirror_hypotheses",
                     "min_depth_m",
                     "max_depth_m",
                     "refine_scales",
                     "refine_robust_scale_px",
                     "edge_high_fraction",
                     "retry_edge_high_fraction",
                     "rescue_depth_factors",
                     "edge_match_depth_factors",
                     "edge_match_nearer_depth_factors",
                     "edge_match_shape_regions",
                     "edge_match_partner_depth_gap",
                     "envelope_penalty_per_unit",
                     "penetration_penalty_per_mm"});
  section.read("direction_step_deg", &s.direction_step_deg);
  section.read("roll_step_deg", &s.roll_step_deg);
  section.read("matches_per_bone", &s.matches_per_bone);
  section.read("screening_scale", &s.screening_scale);
  section.read("refined_per_bone", &s.refined_per_bone);
  section.read("wide_screening_px", &s.wide_screening_px);
  section.read("wide_refined_per_bone", &s.wide_refined_per_bone);
  section.read("envelope_extra_refined", &s.envelope_extra_refined);
  section.read("fine_envelope", &s.fine_envelope);
  section.read("fine_envelope_flexion_step_deg", &s.fine_envelope_flexion_step_deg);
  section.read("fine_envelope_anterior_step_mm", &s.fine_envelope_anterior_step_mm);
  section.read("fine_envelope_neighbour_inliers", &s.fine_envelope_neighbour_inliers);
  section.read("mirror_hypotheses", &s.mirror_hypotheses);
  section.read("min_depth_m", &s.min_depth_m);
  section.read("max_depth_m", &s.max_depth_m);
  section.read("refine_scales", &s.refine_scales);
  section.read("refine_robust_scale_px", &s.refine_robust_scale_px);
  section.read("edge_high_fraction", &s.edge_high_fraction);
  section.read("retry_edge_high_fraction", &s.retry_edge_high_fraction);
  section.read("rescue_depth_factors", &s.rescue_depth_factors);
  section.read("edge_match_depth_factors", &s.edge_match_depth_factors);
  section.read("edge_match_nearer_depth_factors", &s.edge_match_nearer_depth_factors);
  section.read("edge_match_shape_regions", &s.edge_match_shape_regions);
  section.read("edge_match_partner_depth_gap", &s.edge_match_partner_depth_gap);
  section.read("envelope_penalty_per_unit", &s.envelope_penalty_per_unit);
  section.read("penetration_penalty_per_mm", &s.penetration_penalty_per_mm);
  try {
    s.validate();
  } catch (const InputError& e) {
    throw InputError(context + ": " + e.what());
  }
  return s;
}

// The `registration:` section: solver schedule, robust scales and edge detection.
registration::RegistrationSettings readRegistrationSettings(const YAML::Node& node,
                                                            const std::string& context) {
  registration::RegistrationSettings r;
  const YamlSection section(node, context);
  section.allowOnly({"scales",
                     "outer_iterations",
                     "coarse_outer_iterations",
                     "tracking_scales",
                     "tracking_retry",
                     "tracking_retry_inlier_drop",
                     "tracking_inner_edge_margin_px",
                     "tracking_retry_min_inlier_gain",
                     "tracking_retry_max_inlier_loss",
                     "tracking_shift_search_mm",
                     "featureless_noise_ratio",
                     "tracking_recovery_registration",
                     "tracking_restart_after_suspect",
                     "tracking_prediction",
                     "solver_iterations",
                     "contour_spacing_px",
                     "robust_scale_px",
                     "robust_scale_final_px",
                     "roi_margin_px",
                     "reverse_term_weight",
                     "reverse_band_px",
                     "inner_edge_margin_px",
                     "max_translation_from_start_m",
                     "max_rotation_from_start_rad",
                     "converged_translation_m",
                     "converged_rotation_rad",
                     "edge_offset_model",
                     "parameterisation",
                     "edge_offset_prior_px",
                     "edge_offset_min_px",
                     "edge_offset_hold",
                     "corner_rounding",
                     "threads",
                     "rendered_edges",
                     "edge_offset_tracking",
                     "contact_from_outer_iteration",
                     "stages",
                     "edges",
                     "compute_covariance",
                     "covariance_offset_gradient_sd_px",
                     "mirror_check",
                     "reflection_retry",
                     "rotation_retry",
                     "depth_retry",
                     "quality",
                     "search"});
  section.read("compute_covariance", &r.compute_covariance);
  section.read("covariance_offset_gradient_sd_px", &r.covariance_offset_gradient_sd_px);
  const YamlSection quality = section.child("quality");
  quality.allowOnly(
      {"inlier_distance_px", "inliers_at_edge_offset", "lost_inlier_fraction",
       "suspect_inlier_fraction", "suspect_contour_spread_px", "suspect_contour_rms_px",
       "suspect_penetration_mm", "suspect_envelope_violation", "suspect_out_of_plane_sd_mm",
       "suspect_rotation_sd_deg", "relative_inlier_drop", "relative_inlier_spread",
       "relative_inlier_window", "relative_inlier_min_frames", "relative_inlier_trend_frames",
       "unseen_edge_distance_px", "held_by_other_views_inlier_fraction"});
  quality.read("inlier_distance_px", &r.quality.inlier_distance_px);
  quality.read("inliers_at_edge_offset", &r.quality.inliers_at_edge_offset);
  quality.read("lost_inlier_fraction", &r.quality.lost_inlier_fraction);
  quality.read("suspect_inlier_fraction", &r.quality.suspect_inlier_fraction);
  quality.read("suspect_contour_spread_px", &r.quality.suspect_contour_spread_px);
  quality.read("suspect_contour_rms_px", &r.quality.suspect_contour_rms_px);
  quality.read("suspect_penetration_mm", &r.quality.suspect_penetration_mm);
  quality.read("suspect_envelope_violation", &r.quality.suspect_envelope_violation);
  quality.read("suspect_out_of_plane_sd_mm", &r.quality.suspect_out_of_plane_sd_mm);
  quality.read("suspect_rotation_sd_deg", &r.quality.suspect_rotation_sd_deg);
  quality.read("relative_inlier_drop", &r.quality.relative_inlier_drop);
  quality.read("relative_inlier_spread", &r.quality.relative_inlier_spread);
  quality.read("relative_inlier_window", &r.quality.relative_inlier_window);
  quality.read("relative_inlier_min_frames", &r.quality.relative_inlier_min_frames);
  quality.read("relative_inlier_trend_frames", &r.quality.relative_inlier_trend_frames);
  quality.read("unseen_edge_distance_px", &r.quality.unseen_edge_distance_px);
  quality.read("held_by_other_views_inlier_fraction",
               &r.quality.held_by_other_views_inlier_fraction);
  section.read("scales", &r.scales);
  section.read("outer_iterations", &r.outer_iterations);
  section.read("coarse_outer_iterations", &r.coarse_outer_iterations);
  section.read("tracking_scales", &r.tracking_scales);
  section.read("tracking_retry", &r.tracking_retry);
  section.read("tracking_retry_inlier_drop", &r.tracking_retry_inlier_drop);
  section.read("tracking_inner_edge_margin_px", &r.tracking_inner_edge_margin_px);
  section.read("tracking_retry_min_inlier_gain", &r.tracking_retry_min_inlier_gain);
  section.read("tracking_retry_max_inlier_loss", &r.tracking_retry_max_inlier_loss);
  section.read("tracking_shift_search_mm", &r.tracking_shift_search_mm);
  section.read("featureless_noise_ratio", &r.featureless_noise_ratio);
  section.read("tracking_recovery_registration", &r.tracking_recovery_registration);
  section.read("tracking_restart_after_suspect", &r.tracking_restart_after_suspect);
  std::string tracking_prediction = registration::trackingPredictionName(r.tracking_prediction);
  section.read("tracking_prediction", &tracking_prediction);
  section.read("solver_iterations", &r.solver_iterations);
  section.read("contour_spacing_px", &r.contour_spacing_px);
  section.read("robust_scale_px", &r.robust_scale_px);
  section.read("robust_scale_final_px", &r.robust_scale_final_px);
  section.read("roi_margin_px", &r.roi_margin_px);
  section.read("reverse_term_weight", &r.reverse_term_weight);
  section.read("reverse_band_px", &r.reverse_band_px);
  section.read("inner_edge_margin_px", &r.inner_edge_margin_px);
  section.read("max_translation_from_start_m", &r.max_translation_from_start_m);
  section.read("max_rotation_from_start_rad", &r.max_rotation_from_start_rad);
  section.read("converged_translation_m", &r.converged_translation_m);
  section.read("converged_rotation_rad", &r.converged_rotation_rad);
  std::string edge_offset_model = registration::edgeOffsetModelName(r.edge_offset_model);
  section.read("edge_offset_model", &edge_offset_model);
  std::string parameterisation = registration::parameterisationName(r.parameterisation);
  section.read("parameterisation", &parameterisation);
  section.read("edge_offset_prior_px", &r.edge_offset_prior_px);
  section.read("edge_offset_min_px", &r.edge_offset_min_px);
  section.read("edge_offset_hold", &r.edge_offset_hold);
  section.read("corner_rounding", &r.corner_rounding);
  section.read("threads", &r.threads);
  const YamlSection rendered_edges = section.child("rendered_edges");
  rendered_edges.allowOnly({"enabled", "saturation_mm"});
  rendered_edges.read("enabled", &r.rendered_edges.enabled);
  rendered_edges.read("saturation_mm", &r.rendered_edges.saturation_mm);
  const YamlSection offset_tracking = section.child("edge_offset_tracking");
  offset_tracking.allowOnly({"enabled", "frame_sd_px", "drift_px"});
  offset_tracking.read("enabled", &r.edge_offset_tracking.enabled);
  offset_tracking.read("frame_sd_px", &r.edge_offset_tracking.frame_sd_px);
  offset_tracking.read("drift_px", &r.edge_offset_tracking.drift_px);
  section.read("contact_from_outer_iteration", &r.contact_from_outer_iteration);
  if (const YAML::Node stages = node["stages"]) {
    if (!stages.IsSequence()) throw InputError(context + ".stages must be a list");
    for (std::size_t k = 0; k < stages.size(); ++k) {
      const YamlSection st(stages[k], context + ".stages[" + std::to_string(k) + "]");
      st.allowOnly({"outer_iterations", "solver_iterations", "contact", "ligaments",
                    "contact_from_outer_iteration", "image_weights"});
      registration::RegistrationStage stage;
      st.read("outer_iterations", &stage.outer_iterations);
      st.read("solver_iterations", &stage.solver_iterations);
      st.read("contact", &stage.contact);
      st.read("ligaments", &stage.ligaments);
      st.read("contact_from_outer_iteration", &stage.contact_from_outer_iteration);
      st.read("image_weights", &stage.image_weights);
      r.stages.push_back(stage);
    }
  }
  const YamlSection mirror = section.child("mirror_check");
  mirror.allowOnly({"enabled", "cost_tolerance", "min_difference_deg", "max_difference_deg",
                    "min_neutral_gain", "tracking_turn_max_difference_deg",
                    "tracking_tilt_reflection", "outer_iterations", "solver_iterations",
                    "continued_outer_iterations", "turn_reflection", "mirror_reflection",
                    "tilt_reflection", "abandon_cost_ratio", "abandon_deviation_excess",
                    "start_deviation_excess", "neutral_internal_rotation_per_flexion"});
  mirror.read("enabled", &r.mirror_check.enabled);
  mirror.read("cost_tolerance", &r.mirror_check.cost_tolerance);
  mirror.read("min_difference_deg", &r.mirror_check.min_difference_deg);
  mirror.read("max_difference_deg", &r.mirror_check.max_difference_deg);
  mirror.read("min_neutral_gain", &r.mirror_check.min_neutral_gain);
  mirror.read("tracking_turn_max_difference_deg", &r.mirror_check.tracking_turn_max_difference_deg);
  mirror.read("tracking_tilt_reflection", &r.mirror_check.tracking_tilt_reflection);
  mirror.read("outer_iterations", &r.mirror_check.outer_iterations);
  mirror.read("solver_iterations", &r.mirror_check.solver_iterations);
  mirror.read("continued_outer_iterations", &r.mirror_check.continued_outer_iterations);
  mirror.read("turn_reflection", &r.mirror_check.turn_reflection);
  mirror.read("mirror_reflection", &r.mirror_check.mirror_reflection);
  mirror.read("tilt_reflection", &r.mirror_check.tilt_reflection);
  mirror.read("abandon_cost_ratio", &r.mirror_check.abandon_cost_ratio);
  mirror.read("abandon_deviation_excess", &r.mirror_check.abandon_deviation_excess);
  mirror.read("start_deviation_excess", &r.mirror_check.start_deviation_excess);
  mirror.read("neutral_internal_rotation_per_flexion",
              &r.mirror_check.neutral_internal_rotation_per_flexion);
  const YamlSection reflection_retry = section.child("reflection_retry");
  reflection_retry.allowOnly(
      {"enabled", "below_inlier_fraction", "min_inlier_gain", "before_mirror_check"});
  reflection_retry.read("enabled", &r.reflection_retry.enabled);
  reflection_retry.read("below_inlier_fraction", &r.reflection_retry.below_inlier_fraction);
  reflection_retry.read("min_inlier_gain", &r.reflection_retry.min_inlier_gain);
  reflection_retry.read("before_mirror_check", &r.reflection_retry.before_mirror_check);
  const YamlSection rotation_retry = section.child("rotation_retry");
  rotation_retry.allowOnly(
      {"enabled", "above_contour_spread_px", "step_deg", "tracking_spread_rise"});
  rotation_retry.read("enabled", &r.rotation_retry.enabled);
  rotation_retry.read("above_contour_spread_px", &r.rotation_retry.above_contour_spread_px);
  rotation_retry.read("step_deg", &r.rotation_retry.step_deg);
  rotation_retry.read("tracking_spread_rise", &r.rotation_retry.tracking_spread_rise);
  const YamlSection depth_retry = section.child("depth_retry");
  depth_retry.allowOnly(
      {"enabled", "shifts_mm", "light_below_inlier_fraction", "other_views_shift_mm"});
  depth_retry.read("enabled", &r.depth_retry.enabled);
  depth_retry.read("shifts_mm", &r.depth_retry.shifts_mm);
  depth_retry.read("light_below_inlier_fraction", &r.depth_retry.light_below_inlier_fraction);
  depth_retry.read("other_views_shift_mm", &r.depth_retry.other_views_shift_mm);
  const YamlSection edges = section.child("edges");
  edges.allowOnly({"window_low_percentile", "window_high_percentile", "clahe", "clahe_clip_limit",
                   "blur_sigma_px", "canny_low", "canny_high", "auto_high_fraction",
                   "auto_low_ratio", "thresholds_skip_saturated_borders", "min_edge_significance",
                   "edge_significance_low_ratio", "clipped_grey_margin", "max_distance_px",
                   "line_distance_band_px"});
  edges.read("window_low_percentile", &r.edges.window_low_percentile);
  edges.read("window_high_percentile", &r.edges.window_high_percentile);
  edges.read("clahe", &r.edges.clahe);
  edges.read("clahe_clip_limit", &r.edges.clahe_clip_limit);
  edges.read("blur_sigma_px", &r.edges.blur_sigma_px);
  edges.read("canny_low", &r.edges.canny_low);
  edges.read("canny_high", &r.edges.canny_high);
  edges.read("auto_high_fraction", &r.edges.auto_high_fraction);
  edges.read("auto_low_ratio", &r.edges.auto_low_ratio);
  edges.read("thresholds_skip_saturated_borders", &r.edges.thresholds_skip_saturated_borders);
  edges.read("min_edge_significance", &r.edges.min_edge_significance);
  edges.read("edge_significance_low_ratio", &r.edges.edge_significance_low_ratio);
  edges.read("clipped_grey_margin", &r.edges.clipped_grey_margin);
  edges.read("max_distance_px", &r.edges.max_distance_px);
  edges.read("line_distance_band_px", &r.edges.line_distance_band_px);
  try {
    r.edge_offset_model = registration::edgeOffsetModelFromName(edge_offset_model);
    r.parameterisation = registration::parameterisationFromName(parameterisation);
    r.tracking_prediction = registration::trackingPredictionFromName(tracking_prediction);
    r.validate();
  } catch (const InputError& e) {
    throw InputError(context + ": " + e.what());
  }
  return r;
}

}  // namespace

std::vector<geometry::Pose> TrialConfig::initialPoses() const {
  std::vector<geometry::Pose> poses;
  for (const auto& bone : bones) {
    if (!bone.initial_pose) return {};
    poses.push_back(*bone.initial_pose);
  }
  return poses;
}

const BoneConfig* TrialConfig::findBone(const std::string& name) const {
  for (const auto& bone : bones) {
    if (bone.name == name) return &bone;
  }
  return nullptr;
}

TrialConfig loadTrialConfig(const std::string& path) {
  const YAML::Node root = loadYamlFile(path, "trial config");
  if (!root.IsMap()) throw InputError("trial config '" + path + "' must be a YAML map");
  const fs::path base = fs::absolute(path).parent_path();

  TrialConfig config;
  if (root["fixed_frame"]) config.fixed_frame = required<std::string>(root, "fixed_frame", path);

  const YAML::Node bones = root["bones"];
  if (!bones || !bones.IsSequence() || bones.size() == 0) {
    throw InputError("trial config '" + path + "': 'bones' must be a non-empty list");
  }
  std::set<std::string> names;
  for (std::size_t i = 0; i < bones.size(); ++i) {
    const YAML::Node b = bones[i];
    const std::string context = "trial config '" + path + "' bones[" + std::to_string(i) + "]";
    BoneConfig bone;
    bone.name = required<std::string>(b, "name", context);
    if (bone.name.empty()) throw InputError(context + ": empty bone name");
    if (!names.insert(bone.name).second) {
      throw InputError(context + ": bone name '" + bone.name + "' is used twice");
    }
    bone.mesh = resolvePath(base.string(), required<std::string>(b, "mesh", context));
    if (b["mesh_units"]) {
      bone.mesh_units =
          geometry::parseLengthUnit(required<std::string>(b, "mesh_units", context), context);
    }
    if (b["articular_mesh"]) {
      bone.articular_mesh =
          resolvePath(base.string(), required<std::string>(b, "articular_mesh", context));
    }
    if (const YAML::Node pose = b["initial_pose"]) {
      bone.initial_pose = readYamlPose(pose, context + ".initial_pose");
    }
    if (b["image_weight"]) bone.image_weight = required<double>(b, "image_weight", context);
    if (!(bone.image_weight >= 0.0)) throw InputError(context + ": image_weight must be >= 0");
    if (const YAML::Node frame = b["anatomical_frame"]) {
      bone.anatomical_frame = readYamlPose(frame, context + ".anatomical_frame");
    }
    config.bones.push_back(std::move(bone));
  }

  if (root["registration"]) {
    config.registration =
        readRegistrationSettings(root["registration"], "trial config '" + path + "' registration");
    config.search = readSearchSettings(root["registration"]["search"],
                                       "trial config '" + path + "' registration.search");
  }

  if (const YAML::Node joints = root["joints"]) {
    if (!joints.IsSequence())
      throw InputError("trial config '" + path + "': 'joints' must be a list");
    for (std::size_t i = 0; i < joints.size(); ++i) {
      const YAML::Node j = joints[i];
      const std::string context = "trial config '" + path + "' joints[" + std::to_string(i) + "]";
      JointConfig joint;
      joint.name = required<std::string>(j, "name", context);
      joint.parent = required<std::string>(j, "parent", context);
      joint.child = required<std::string>(j, "child", context);
      if (j["type"]) joint.type = required<std::string>(j, "type", context);
      kinematics::JointType type = kinematics::JointType::kKnee;
      try {
        type = kinematics::jointTypeFromName(joint.type);
      } catch (const InputError& e) {
        throw InputError(context + ": " + e.what());
      }
      for (const auto& bone : {joint.parent, joint.child}) {
        if (!names.count(bone)) {
          throw InputError(context + ": bone '" + bone + "' is not listed under 'bones'");
        }
      }
      joint.contact = readContactSettings(j, context);
      joint.ligaments = readLigamentSettings(j, context, type);
      if (j["side"]) {
        try {
          joint.side = kinematics::sideFromName(required<std::string>(j, "side", context));
        } catch (const InputError& e) {
          throw InputError(context + ": " + e.what());
        }
      }
      config.joints.push_back(std::move(joint));
    }
  }
  return config;
}

void saveTrialConfig(const std::string& path, const TrialConfig& config) {
  const fs::path base = fs::absolute(path).parent_path();
  const auto relative = [&base](const std::string& p) {
    const fs::path rel = fs::path(p).lexically_relative(base);
    return (!rel.empty() && *rel.begin() != "..") ? rel.string() : p;
  };
  YAML::Emitter out;
  out.SetDoublePrecision(12);  // sub-nanometre for poses in metres; 0.7 stays 0.7
  out << YAML::BeginMap;
  if (!config.fixed_frame.empty())
    out << YAML::Key << "fixed_frame" << YAML::Value << config.fixed_frame;
  out << YAML::Key << "bones" << YAML::Value << YAML::BeginSeq;
  for (const auto& bone : config.bones) {
    out << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << bone.name;
    out << YAML::Key << "mesh" << YAML::Value << relative(bone.mesh);
    out << YAML::Key << "mesh_units" << YAML::Value << geometry::toString(bone.mesh_units);
    if (!bone.articular_mesh.empty()) {
      out << YAML::Key << "articular_mesh" << YAML::Value << relative(bone.articular_mesh);
    }
    if (bone.image_weight != 1.0)
      out << YAML::Key << "image_weight" << YAML::Value << bone.image_weight;
    if (bone.initial_pose) writePose(&out, "initial_pose", *bone.initial_pose);
    if (!bone.anatomical_frame.isApprox(geometry::Pose::Identity())) {
      writePose(&out, "anatomical_frame", bone.anatomical_frame);
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!config.joints.empty()) {
    out << YAML::Key << "joints" << YAML::Value << YAML::BeginSeq;
    for (const auto& joint : config.joints) {
      out << YAML::BeginMap;
      out << YAML::Key << "name" << YAML::Value << joint.name;
      out << YAML::Key << "parent" << YAML::Value << joint.parent;
      out << YAML::Key << "child" << YAML::Value << joint.child;
      out << YAML::Key << "type" << YAML::Value << joint.type;
      out << YAML::Key << "side" << YAML::Value << kinematics::sideName(joint.side);
      const constraints::ContactSettings& c = joint.contact;
      out << YAML::Key << "contact" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "enabled" << YAML::Value << c.enabled;
      out << YAML::Key << "measure" << YAML::Value << constraints::contactMeasureName(c.measure);
      out << YAML::Key << "dead_band_mm" << YAML::Value << c.dead_band_mm;
      out << YAML::Key << "exponent" << YAML::Value << c.exponent;
      out << YAML::Key << "weight" << YAML::Value << c.weight;
      out << YAML::Key << "loaded_weight" << YAML::Value << c.loaded_weight;
      out << YAML::Key << "max_sample_spacing_mm" << YAML::Value << c.max_sample_spacing_mm;
      out << YAML::Key << "grid_spacing_mm" << YAML::Value << c.grid.spacing_m * 1e3;
      out << YAML::Key << "grid_margin_mm" << YAML::Value << c.grid.margin_m * 1e3;
      out << YAML::Key << "grid_exact_band_mm" << YAML::Value << c.grid.exact_band_m * 1e3;
      if (!c.region.box.isEmpty() || c.region.normal.squaredNorm() > 0.0) {
        out << YAML::Key << "region" << YAML::Value << YAML::BeginMap;
        if (!c.region.box.isEmpty()) {
          const Eigen::Vector3d lo = 1e3 * c.region.box.min();
          const Eigen::Vector3d hi = 1e3 * c.region.box.max();
          out << YAML::Key << "box_min_mm" << YAML::Value << YAML::Flow
              << std::vector<double>{lo.x(), lo.y(), lo.z()};
          out << YAML::Key << "box_max_mm" << YAML::Value << YAML::Flow
              << std::vector<double>{hi.x(), hi.y(), hi.z()};
        }
        if (c.region.normal.squaredNorm() > 0.0) {
          out << YAML::Key << "normal" << YAML::Value << YAML::Flow
              << std::vector<double>{c.region.normal.x(), c.region.normal.y(), c.region.normal.z()};
        }
        out << YAML::Key << "max_angle_deg" << YAML::Value << c.region.max_angle_deg;
        out << YAML::EndMap;
      }
      out << YAML::EndMap;
      const kinematics::JointType type = kinematics::jointTypeFromName(joint.type);
      // A shoulder without springs holds no bounds of its own (readLigamentSettings).
      if (joint.ligaments.enabled || kinematics::hasKneeFrameCoordinates(type)) {
        const constraints::LigamentSettings& l = joint.ligaments;
        out << YAML::Key << "ligaments" << YAML::Value << YAML::BeginMap;
        out << YAML::Key << "enabled" << YAML::Value << l.enabled;
        const auto names = ligamentKeys(type);
        for (int k = 0; k < 6; ++k) {
          // The sign change of the first angle is its own inverse.
          const constraints::CoordinateBounds b =
              k == 0 ? firstAngleBounds(type, l.bounds[k]) : l.bounds[k];
          out << YAML::Key << names[k] << YAML::Value << YAML::Flow
              << std::vector<double>{b.lower, b.upper};
        }
        out << YAML::Key << "stiffness_per_deg" << YAML::Value << l.stiffness_per_deg;
        out << YAML::Key << "stiffness_per_mm" << YAML::Value << l.stiffness_per_mm;
        if (!l.bundles.empty()) {
          out << YAML::Key << "bundles" << YAML::Value << YAML::BeginSeq;
          for (const auto& b : l.bundles) {
            const auto mm = [](const Eigen::Vector3d& m) {
              return std::vector<double>{1e3 * m.x(), 1e3 * m.y(), 1e3 * m.z()};
            };
            out << YAML::BeginMap;
            out << YAML::Key << "name" << YAML::Value << b.name;
            out << YAML::Key << "parent_insertion_mm" << YAML::Value << YAML::Flow
                << mm(b.parent_insertion_m);
            out << YAML::Key << "child_insertion_mm" << YAML::Value << YAML::Flow
                << mm(b.child_insertion_m);
            out << YAML::Key << "slack_length_mm" << YAML::Value << 1e3 * b.slack_length_m;
            out << YAML::Key << "stiffness_per_mm" << YAML::Value << b.stiffness_per_mm;
            out << YAML::EndMap;
          }
          out << YAML::EndSeq;
        }
        out << YAML::EndMap;
      }
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  std::ofstream file(path);
  if (!file) throw InputError("cannot write trial config '" + path + "'");
  file << "# fluoro_tracker trial configuration (see README and docs: interfaces.md)\n"
       << out.c_str() << "\n";
  if (!file) throw InputError("failed while writing trial config '" + path + "'");
}

}  // namespace io
}  // namespace fluoro_tracker
