#include "fluoro_tracker/registration/pose_search.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include "fluoro_tracker/imaging/featureless_frame.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/median.h"
#include "fluoro_tracker/parallel_for.h"
#include "fluoro_tracker/registration/joint_envelope.h"
#include "fluoro_tracker/registration/mirror_ambiguity.h"

namespace fluoro_tracker {
namespace registration {
namespace {

// A bone's pose that one start refined to, and how well the image supports it.
struct Hypothesis {
  geometry::Pose pose;
  double support = 0.0;  // contour inlier fraction
};

bool isSameHypothesis(const geometry::Pose& a, const geometry::Pose& b) {
  return (a.translation() - b.translation()).norm() < 2e-3 &&
         geometry::rotationAngleBetween(a.linear(), b.linear()) < geometry::degToRad(2.0);
}

// A match's pose (camera frame), if its distance from the source is plausible for a bone.
std::optional<geometry::Pose> plausibleMatchPose(const imaging::SilhouetteLibrary& library,
                                                 const imaging::ShapeMatch& match,
                                                 const imaging::ImplantBlob& blob,
                                                 const geometry::XrayCamera& camera,
                                                 const PoseSearchSettings& settings) {
  const geometry::Pose pose = library.cameraFromMesh(match, blob, camera);
  const double depth = pose.translation().z();
  if (!pose.translation().allFinite() || depth < settings.min_depth_m ||
      depth > settings.max_depth_m) {
    return std::nullopt;
  }
  return pose;
}

// The image's starting poses for one bone (camera frame): the best shape matches over all
// regions, and each region's own best match, each with the pose its region's size and place
// imply. A region of background (a bone end, soft tissue) can outmatch the implant's own region
// for every one of the overall best; its own best match keeps the implant's region in the
// search, and the screening against the image's edges then decides.
std::vector<geometry::Pose> shapeMatchStarts(const imaging::SilhouetteLibrary& library,
                                             const std::vector<imaging::ImplantBlob>& blobs,
                                             const geometry::XrayCamera& camera,
                                             const PoseSearchSettings& settings, int threads,
                                             std::vector<std::size_t>* best_regions = nullptr) {
  const int count = settings.matches_per_bone;
  struct Start {
    double dissimilarity;
    std::size_t blob;
    geometry::Pose pose;
  };
  std::vector<Start> starts;
  for (std::size_t b = 0; b < blobs.size(); ++b) {
    for (const auto& match :
         library.match(blobs[b], count, settings.roll_step_deg,
                       imaging::SilhouetteLibrary::kShapeMinSeparationDeg, threads)) {
      if (const auto pose = plausibleMatchPose(library, match, blobs[b], camera, settings)) {
        starts.push_back({match.dissimilarity, b, *pose});
      }
    }
  }
  std::stable_sort(starts.begin(), starts.end(), [](const Start& a, const Start& b) {
    return a.dissimilarity < b.dissimilarity;
  });
  std::vector<geometry::Pose> poses;
  std::vector<bool> region_started(blobs.size(), false);
  for (std::size_t k = 0; k < starts.size(); ++k) {
    // Sorted: a region's first start is its best match.
    if (!region_started[starts[k].blob] && best_regions != nullptr) {
      best_regions->push_back(starts[k].blob);
    }
    if (static_cast<int>(k) < count || !region_started[starts[k].blob]) {
      poses.push_back(starts[k].pose);
      region_started[starts[k].blob] = true;
    }
  }
  return poses;
}

// Chamfer distances are truncated at matchEdges' default, so that no larger one is needed.
constexpr double kChamferTruncationPx = 3.0;

// Starting poses for one bone (camera frame) from chamfer matching of its library on the
// coarse map's edges (`edge_distance`: the map's unsignedDistance(kChamferTruncationPx)),
// around the largest candidate regions and the first edge_match_shape_regions of
// `also_regions` (indices into `blobs`), at `factors` of the distance `depths` suggest (their
// median: from the joint's combined silhouettes and the bone's own matches, or a joint
// partner's distance. A thresholded region is smaller than the silhouette, so the factors are
// 1 or less).
std::vector<geometry::Pose> edgeMatchStarts(
    const imaging::SilhouetteLibrary& library, const std::vector<imaging::ImplantBlob>& blobs,
    const std::vector<std::size_t>& also_regions, const imaging::EdgeMap& coarse,
    const cv::Mat& edge_distance, const std::vector<double>& depths,
    const std::vector<double>& factors, const PoseSearchSettings& settings, int threads) {
  if (depths.empty() || factors.empty()) return {};
  const geometry::XrayCamera& camera = coarse.camera();
  const double focal = std::sqrt(camera.fx() * camera.fy());
  const double depth = median(depths);
  if (!(depth >= settings.min_depth_m && depth <= settings.max_depth_m)) return {};
  std::vector<double> px_per_m;
  for (const double factor : factors) {
    px_per_m.push_back(focal / (factor * depth));
  }
  // Around the largest regions (a merged joint is the largest): their boxes plus a margin.
  std::vector<const imaging::ImplantBlob*> largest;
  for (const auto& blob : blobs) largest.push_back(&blob);
  std::sort(largest.begin(), largest.end(),
            [](const auto* a, const auto* b) { return a->area_px > b->area_px; });
  largest.resize(std::min<std::size_t>(largest.size(), settings.edge_match_regions));
  // ... and around the given ones, if not among them.
  for (std::size_t k = 0;
       k < also_regions.size() && static_cast<int>(k) < settings.edge_match_shape_regions; ++k) {
    const imaging::ImplantBlob* blob = &blobs[also_regions[k]];
    if (std::find(largest.begin(), largest.end(), blob) == largest.end()) largest.push_back(blob);
  }
  std::vector<geometry::Pose> poses;
  for (const imaging::ImplantBlob* blob : largest) {
    const double to_map = coarse.scale() / blob->scale;
    cv::Rect box(static_cast<int>(std::floor(blob->box.x * to_map)) - coarse.roi().x,
                 static_cast<int>(std::floor(blob->box.y * to_map)) - coarse.roi().y,
                 static_cast<int>(std::ceil(blob->box.width * to_map)),
                 static_cast<int>(std::ceil(blob->box.height * to_map)));
    const int margin = std::max(box.width, box.height) / 6;
    box = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin);
    // About 30 positions across the box at most: the cost stays bounded on large regions.
    const double step =
        std::max(settings.edge_position_step_px, std::max(box.width, box.height) / 30.0);
    for (const imaging::EdgeMatch& match :
         library.matchEdges(edge_distance, box, px_per_m, settings.edge_matches_per_bone,
                            settings.edge_roll_step_deg, step, kChamferTruncationPx,
                            imaging::SilhouetteLibrary::kEdgeMinSeparationDeg,
                            imaging::SilhouetteLibrary::kEdgeMinSeparationPx, threads)) {
      poses.push_back(library.cameraFromMesh(match, camera));
    }
  }
  return poses;
}

// How well a pose's projected contour lies on the coarse map's edges: the share of contour
// samples within one coarse pixel of an edge, and within `wide_px` (0 when the bone is not in
// the view).
struct ScreeningScores {
  double near = 0.0;
  double wide = 0.0;
};

ScreeningScores screeningScores(const imaging::SilhouetteModel& silhouette,
                                const geometry::Pose& pose, const imaging::EdgeMap& coarse,
                                double wide_px) {
  const geometry::XrayCamera& camera = coarse.camera();
  const geometry::Pose camera_from_mesh = camera.worldFromCamera().inverse() * pose;
  if (camera_from_mesh.translation().z() <= 0.0) return {};
  const auto contour = silhouette.contour(camera, camera_from_mesh, 1.0);
  if (contour.empty()) return {};
  int near = 0;
  int wide = 0;
  for (const auto& c : contour) {
    double d = 0.0;
    double du = 0.0;
    double dv = 0.0;
    if (!coarse.sample(c.pixel.x(), c.pixel.y(), &d, &du, &dv)) continue;
    if (std::abs(d) <= 1.0) ++near;
    if (std::abs(d) <= wide_px) ++wide;
  }
  const double count = static_cast<double>(contour.size());
  return {near / count, wide / count};
}

}  // namespace

void PoseSearchSettings::validate() const {
  if (!(direction_step_deg > 1.0 && direction_step_deg < 90.0)) {
    throw InputError("registration search: direction_step_deg must be in (1, 90)");
  }
  if (!(joint_direction_step_deg > 1.0 && joint_direction_step_deg < 90.0) ||
      !(joint_flexion_step_deg > 0.5) || joint_matches < 0) {
    throw InputError(
        "registration search: joint_direction_step_deg in (1, 90), joint_flexion_step_deg > 0.5 "
        "and joint_matches >= 0 are needed");
  }
  if (!(roll_step_deg > 0.5 && roll_step_deg <= 90.0)) {
    throw InputError("registration search: roll_step_deg must be in (0.5, 90]");
  }
  if (!(min_depth_m > 0.0 && max_depth_m > min_depth_m)) {
    throw InputError("registration search: needs 0 < min_depth_m < max_depth_m");
  }
  if (matches_per_bone < 1 || refined_per_bone < 1) {
    throw InputError("registration search: matches_per_bone and refined_per_bone must be >= 1");
  }
  if (envelope_extra_refined < 0) {
    throw InputError("registration search: envelope_extra_refined must be >= 0");
  }
  if (!(fine_envelope_flexion_step_deg >= 1.0) || !(fine_envelope_anterior_step_mm >= 1.0) ||
      !(fine_envelope_neighbour_inliers >= 0.0 && fine_envelope_neighbour_inliers <= 1.0)) {
    throw InputError(
        "registration search: fine_envelope_flexion_step_deg >= 1, fine_envelope_anterior_step_mm "
        ">= 1 and fine_envelope_neighbour_inliers in [0, 1] are needed");
  }
  if (wide_refined_per_bone < 0 || !(wide_screening_px >= 1.0)) {
    throw InputError(
        "registration search: wide_refined_per_bone must be >= 0 and wide_screening_px >= 1");
  }
  if (!(screening_scale > 0.0 && screening_scale <= 1.0)) {
    throw InputError("registration search: screening_scale must be in (0, 1]");
  }
  if (refine_scales.empty()) throw InputError("registration search: refine_scales is empty");
  if (!(edge_high_fraction > 0.0 && edge_high_fraction <= 1.0)) {
    throw InputError("registration search: edge_high_fraction must be in (0, 1]");
  }
  if (!(retry_edge_high_fraction >= 0.0 && retry_edge_high_fraction <= 1.0)) {
    throw InputError("registration search: retry_edge_high_fraction must be in [0, 1] (0: none)");
  }
  if (!(refine_robust_scale_px > 0.0)) {
    throw InputError("registration search: refine_robust_scale_px must be > 0");
  }
  for (double s : refine_scales) {
    if (!(s > 0.0 && s <= 1.0)) throw InputError("registration search: refine_scales in (0, 1]");
  }
  if (finalists < 1) throw InputError("registration search: finalists must be >= 1");
  for (const double factor : rescue_depth_factors) {
    if (!(factor > 0.5 && factor < 2.0) || factor == 1.0) {
      throw InputError(
          "registration search: rescue_depth_factors must lie in (0.5, 2) and not be 1");
    }
  }
  for (const auto& [name, factors] :
       {std::pair<const char*, const std::vector<double>&>{"edge_match_depth_factors",
                                                           edge_match_depth_factors},
        {"edge_match_nearer_depth_factors", edge_match_nearer_depth_factors}}) {
    for (const double factor : factors) {
      if (!(factor > 0.5 && factor < 2.0)) {
        throw InputError(std::string("registration search: ") + name + " must lie in (0.5, 2)");
      }
    }
  }
  if (edge_match_shape_regions < 0 || !(edge_match_partner_depth_gap >= 0.0) ||
      !std::isfinite(edge_match_partner_depth_gap)) {
    throw InputError(
        "registration search: edge_match_shape_regions >= 0 and a finite "
        "edge_match_partner_depth_gap >= 0 are needed");
  }
  if (edge_matches_per_bone < 0 || edge_match_regions < 0 ||
      !(edge_roll_step_deg > 0.5 && edge_roll_step_deg <= 90.0) ||
      !(edge_position_step_px >= 1.0)) {
    throw InputError(
        "registration search: edge_matches_per_bone >= 0, edge_match_regions >= 0, "
        "edge_roll_step_deg in (0.5, 90] and edge_position_step_px >= 1 are needed");
  }
  if (!(envelope_penalty_per_unit >= 0.0) || !(penetration_penalty_per_mm >= 0.0) ||
      !(neutral_penalty_per_unit >= 0.0)) {
    throw InputError("registration search: penalties must be >= 0");
  }
  if (blobs.threshold_fractions.empty() || blobs.working_size_px < 32 || blobs.field_edge_px < 0 ||
      !(blobs.min_field_fraction >= 0.0)) {
    throw InputError(
        "registration search: blobs need thresholds, working_size_px >= 32, field_edge_px >= 0 "
        "and min_field_fraction >= 0");
  }
}

PoseSearch::PoseSearch(std::shared_ptr<const Registrar> registrar, PoseSearchSettings settings)
    : registrar_(std::move(registrar)), settings_(std::move(settings)) {
  if (!registrar_) throw InputError("pose search: no registrar");
  settings_.validate();
  RegistrationSettings refine = registrar_->settings();
  refine.scales = settings_.refine_scales;
  refine.stages.clear();
  refine.compute_covariance = false;
  // Measured: starts tens of millimetres off along the beam fare better with the offset free at
  // every scale (RegistrationSettings::edge_offset_hold).
  refine.edge_offset_hold = false;
  // ... and without a floor under it: the final joint registration has it
  // (RegistrationSettings::edge_offset_min_px).
  refine.edge_offset_min_px = -std::numeric_limits<double>::infinity();
  // Each start is one hypothesis among many; the search itself covers depth.
  refine.depth_retry.enabled = false;
  refine.reflection_retry.enabled = false;
  refine.rotation_retry.enabled = false;
  // Hypotheses are screened and chosen by their contour's inlier support; local equalisation
  // raises clutter edges everywhere, which lends wrong hypotheses support (real Kneel frame
  // 0180: a tibial tray turned 28 deg about its stem won). The search works on the window
  // alone; the final joint registration uses the trial's edge settings.
  refine.edges.clahe = false;
  // Over the whole frame on the window alone, open air's border against the skin sets
  // thresholds high enough to keep soft tissue's edges out of the screening; without it a
  // bright femoral component in deep flexion lost to clutter (pose_search_test).
  refine.edges.thresholds_skip_saturated_borders = false;
  // Starts are several pixels off at the coarsest scale: a wider robust kernel keeps their
  // edges in the basin (the final joint registration uses the trial's own settings).
  refine.robust_scale_px = std::max(refine.robust_scale_px, settings_.refine_robust_scale_px);
  // ... to the end: a hypothesis's outline may still be pixels off where the finest scale
  // begins (the narrower final kernel is the final joint registration's).
  refine.robust_scale_final_px = 0.0;
  // Shape matching is good to tens of millimetres along the beam and a view step in angle.
  refine.max_translation_from_start_m = std::max(refine.max_translation_from_start_m, 0.1);
  refine.max_rotation_from_start_rad = std::max(refine.max_rotation_from_start_rad, 0.8);
  std::vector<double> high_fractions = {settings_.edge_high_fraction};
  if (settings_.retry_edge_high_fraction > 0.0) {
    high_fractions.push_back(settings_.retry_edge_high_fraction);
  }
  for (const double high_fraction : high_fractions) {
    refine.edges.auto_high_fraction = high_fraction;
    EdgePass pass;
    pass.edges = refine.edges;
    for (const auto& bone : registrar_->bones()) {
      pass.refiners.push_back(std::make_unique<Registrar>(std::vector<BoneModel>{bone}, refine));
    }
    passes_.push_back(std::move(pass));
  }
  for (const auto& bone : registrar_->bones()) {
    libraries_.push_back(std::make_unique<imaging::SilhouetteLibrary>(
        bone.silhouette->mesh(), settings_.direction_step_deg));
  }
  for (const JointModel& joint : registrar_->joints()) {
    envelope_.push_back(envelopeSamples(joint, 10.0, false));
    if (!settings_.joint_silhouettes) continue;
    // The two bones together, across the flexion range: a region where their silhouettes
    // merge (in flexion they overlap in a lateral view) is matched as a whole.
    for (const geometry::Pose& child_in_parent :
         envelopeSamples(joint, settings_.joint_flexion_step_deg, true)) {
      geometry::Mesh together = registrar_->bones()[joint.parent].silhouette->mesh();
      together.append(
          registrar_->bones()[joint.child].silhouette->mesh().transformed(child_in_parent));
      joint_libraries_.push_back({static_cast<std::size_t>(&joint - registrar_->joints().data()),
                                  child_in_parent,
                                  std::make_unique<imaging::SilhouetteLibrary>(
                                      together, settings_.joint_direction_step_deg)});
    }
  }
}

PoseSearchResult PoseSearch::search(const std::vector<ViewImage>& views,
                                    const std::vector<geometry::Pose>& seeds) const {
  const auto start = std::chrono::steady_clock::now();
  const std::size_t bones = registrar_->bones().size();
  if (views.empty()) throw InputError("pose search: no views");
  if (!seeds.empty() && seeds.size() != bones) {
    throw InputError("pose search: " + std::to_string(seeds.size()) + " seed pose(s) for " +
                     std::to_string(bones) + " bone(s)");
  }
  // Its regions come from the first view: in one that shows nothing, every noise speck is one.
  const std::string nothing = imaging::featurelessFrame(
      views.front().image, registrar_->settings().featureless_noise_ratio);
  if (!nothing.empty()) {
    throw InputError("pose search: the " + std::string(views.size() > 1 ? "first view" : "frame") +
                     " shows " + nothing + ": no bone to find");
  }
  // Every result a search returns, rescued first if a bone is still in doubt.
  const auto finish = [&](PoseSearchResult found, int passes) {
    found = rescueAlongSightLines(views, std::move(found));
    found.passes = passes;
    found.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return found;
  };
  // Candidate regions do not depend on the edge settings: found once for both passes.
  const std::vector<imaging::ImplantBlob> blobs =
      imaging::findImplantBlobs(views.front().image, settings_.blobs);
  std::optional<PoseSearchResult> first;
  std::optional<InputError> first_error;
  try {
    first = searchPass(passes_.front(), views, seeds, blobs);
  } catch (const InputError& e) {
    first_error = e;  // nothing found with the first pass's edges
  }
  const QualitySettings& quality = registrar_->settings().quality;
  if (first && resultRank(first->registration, quality).first == 0) {
    return finish(std::move(*first), 1);
  }
  if (passes_.size() < 2) {
    if (first_error) throw *first_error;
    return finish(std::move(*first), 1);
  }
  PoseSearchResult retry;
  try {
    retry = searchPass(passes_[1], views, seeds, blobs);
  } catch (const InputError&) {
    if (first_error) throw *first_error;
    return finish(std::move(*first), 2);
  }
  if (first_error) return finish(std::move(retry), 2);
  // Fewer bones suspect or lost first; between equal statuses, the better explanation.
  const int retry_trouble = resultRank(retry.registration, quality).first;
  const int first_trouble = resultRank(first->registration, quality).first;
  const bool retry_better = retry_trouble < first_trouble ||
                            (retry_trouble == first_trouble && retry.score > first->score);
  return finish(retry_better ? std::move(retry) : std::move(*first), 2);
}

PoseSearchResult PoseSearch::rescueAlongSightLines(const std::vector<ViewImage>& views,
                                                   PoseSearchResult found) const {
  const QualitySettings& quality = registrar_->settings().quality;
  int best_trouble = resultRank(found.registration, quality).first;
  if (best_trouble == 0 || settings_.rescue_depth_factors.empty()) return found;
  const geometry::Pose& world_from_camera = views.front().camera.worldFromCamera();
  const geometry::Pose camera_from_world = world_from_camera.inverse();
  const std::vector<geometry::Pose> from = found.registration.poses;
  bool rescued = false;
  for (const double factor : settings_.rescue_depth_factors) {
    // Each bone moved along its line of sight through the source: its projected place stays,
    // its size changes by 1 / factor.
    std::vector<geometry::Pose> starts;
    for (const geometry::Pose& pose : from) {
      geometry::Pose in_camera = camera_from_world * pose;
      in_camera.translation() *= factor;
      starts.push_back(world_from_camera * in_camera);
    }
    RegistrationResult registered;
    try {
      registered = registrar_->solve(views, starts);
    } catch (const InputError&) {
      continue;  // a start outside the views
    }
    const int trouble = resultRank(registered, quality).first;
    const double score = finalistScore(registered);
    // Only a result the status doubts less replaces the search's: at equal statuses a higher
    // score is no sign of a truer pose (a tracked trial's first frame, rescued at its tray's
    // unchanged suspect status, set its tracking on another path that lost two frames).
    if (trouble < best_trouble || (trouble == best_trouble && rescued && score > found.score)) {
      rescued = true;
      best_trouble = trouble;
      found.registration = std::move(registered);
      found.status = classifyBones(found.registration, quality);
      found.score = score;
      found.rescue_depth_factor = factor;
    }
  }
  return found;
}

const std::vector<std::vector<geometry::Pose>>& PoseSearch::fineEnvelope() const {
  std::call_once(fine_envelope_built_, [this] {
    for (const JointModel& joint : registrar_->joints()) {
      fine_envelope_.push_back(envelopeSamples(joint, settings_.fine_envelope_flexion_step_deg,
                                               false, settings_.fine_envelope_anterior_step_mm));
    }
  });
  return fine_envelope_;
}

double PoseSearch::jointPenalty(double envelope_violation, double penetration_m) const {
  return settings_.envelope_penalty_per_unit * envelope_violation +
         settings_.penetration_penalty_per_mm * 1e3 * penetration_m;
}

double PoseSearch::finalistScore(const RegistrationResult& registered) const {
  double score = 0.0;
  for (std::size_t b = 0; b < registered.poses.size(); ++b) {
    score += registered.diverged[b] ? 0.0 : registered.quality[b].contour_inlier_fraction;
  }
  for (std::size_t j = 0; j < registered.joints.size(); ++j) {
    const JointResult& joint = registered.joints[j];
    score -= jointPenalty(joint.quality.envelope_violation, joint.quality.penetration_m);
    // Between equally good fits (a mirror pose), the joint nearer neutral (see
    // Registrar's mirror check).
    // The neutral rotation that comes with flexion is the tibia's (a knee's).
    const kinematics::JointType type = registrar_->joints()[j].type;
    if (kinematics::hasKneeFrameCoordinates(type)) {
      score -= settings_.neutral_penalty_per_unit *
               neutralDeviation(
                   registrar_->joints()[j].ligaments, joint.coordinates,
                   type == kinematics::JointType::kKnee
                       ? registrar_->settings().mirror_check.neutral_internal_rotation_per_flexion
                       : 0.0);
    }
  }
  return score;
}

PoseSearchResult PoseSearch::searchPass(const EdgePass& pass, const std::vector<ViewImage>& views,
                                        const std::vector<geometry::Pose>& seeds,
                                        const std::vector<imaging::ImplantBlob>& blobs) const {
  const std::size_t bones = registrar_->bones().size();
  const int threads = registrar_->settings().threads;
  const ViewImage& first = views.front();
  const geometry::Pose& world_from_camera = first.camera.worldFromCamera();
  const geometry::Pose camera_from_world = world_from_camera.inverse();
  PoseSearchResult found;
  found.regions = static_cast<int>(blobs.size());
  // Parts of regions split at a neck are matched and refined apart from the whole regions: on
  // a frame whose regions are sound they would only crowd the whole regions' starts out.
  std::vector<imaging::ImplantBlob> regions;
  std::vector<imaging::ImplantBlob> neck_parts;
  for (const auto& blob : blobs) (blob.neck_part ? neck_parts : regions).push_back(blob);
  const imaging::EdgeMap coarse(first.image, first.camera, pass.edges, cv::Rect(),
                                settings_.screening_scale);

  // Screens starts on the coarse edge map and refines the best few, one bone at a time.
  std::vector<std::vector<Hypothesis>> hypotheses(bones);
  const double suspect_fraction = registrar_->settings().quality.suspect_inlier_fraction;
  // `extra_refined`: this many more of the best-screened starts are refined, and kept only
  // where they fit (suspect_inlier_fraction): ill-fitting ones would only crowd the finalists.
  const auto refineBest = [&](std::size_t b, std::vector<geometry::Pose> starts,
                              int extra_refined = 0) {
    std::vector<std::pair<double, geometry::Pose>> screened;
    std::vector<std::pair<double, geometry::Pose>> screened_wide;
    for (const geometry::Pose& s : starts) {
      const ScreeningScores scores = screeningScores(*registrar_->bones()[b].silhouette, s, coarse,
                                                     settings_.wide_screening_px);
      screened.emplace_back(scores.near, s);
      screened_wide.emplace_back(scores.wide, s);
    }
    std::vector<geometry::Pose> refined_starts;
    const auto takeBest = [&](std::vector<std::pair<double, geometry::Pose>>* ranked, int count) {
      std::stable_sort(ranked->begin(), ranked->end(),
                       [](const auto& x, const auto& y) { return x.first > y.first; });
      int taken = 0;
      for (const auto& [score, pose] : *ranked) {
        if (taken >= count) break;
        const bool distinct = std::none_of(
            refined_starts.begin(), refined_starts.end(),
            [&](const geometry::Pose& other) { return isSameHypothesis(other, pose); });
        if (distinct) {
          refined_starts.push_back(pose);
          ++taken;
        }
      }
    };
    takeBest(&screened, settings_.refined_per_bone);
    const std::size_t first_extra = refined_starts.size();
    takeBest(&screened, extra_refined);
    const std::size_t end_extra = refined_starts.size();
    takeBest(&screened_wide, settings_.wide_refined_per_bone);
    // Each start is refined on its own, so threads may share them out; the hypotheses are then
    // merged in the starts' order, as one thread would.
    std::vector<std::optional<RegistrationResult>> results(refined_starts.size());
    parallelFor(refined_starts.size(), threads, [&](std::size_t k) {
      try {
        results[k] = pass.refiners[b]->solve(views, {refined_starts[k]});
      } catch (const InputError&) {
        // a start behind the source or outside the views: not a hypothesis
      }
    });
    for (std::size_t k = 0; k < results.size(); ++k) {
      if (!results[k]) continue;
      RegistrationResult refined = std::move(*results[k]);
      ++found.hypotheses;
      // A refinement stopped for travelling too far from its start (diverged) still returns the
      // last pose within reach, measured like any other: a start 100 mm off along the beam (a
      // region's size misjudged by 10 %) can reach the implant's true pose only just outside.
      if (!geometry::isValidPose(refined.poses[0])) continue;
      const Hypothesis h{refined.poses[0], refined.quality[0].contour_inlier_fraction};
      if (k >= first_extra && k < end_extra && h.support < suspect_fraction) continue;
      auto same =
          std::find_if(hypotheses[b].begin(), hypotheses[b].end(),
                       [&](const Hypothesis& o) { return isSameHypothesis(o.pose, h.pose); });
      if (same == hypotheses[b].end()) {
        hypotheses[b].push_back(h);
      } else if (h.support > same->support) {
        *same = h;
      }
    }
  };
  // No hypothesis of bone b reaches the suspect inlier fraction yet.
  const auto foundPoorly = [&](std::size_t b) {
    return std::none_of(hypotheses[b].begin(), hypotheses[b].end(),
                        [&](const Hypothesis& h) { return h.support >= suspect_fraction; });
  };

  // A camera-frame start moved to the fixed frame, with its mirror hypothesis.
  const auto addStart = [&](std::vector<geometry::Pose>* starts,
                            const geometry::Pose& camera_pose) {
    starts->push_back(world_from_camera * camera_pose);
    if (settings_.mirror_hypotheses) {
      starts->push_back(world_from_camera * mirroredAcrossBeam(camera_pose));
    }
  };

  // 1. Each bone on its own: shape matches of the image's regions, mirrored, at a few
  // distances (a region thresholded from a blurred rim is smaller than the silhouette); and
  // both bones of a joint from matches of the joint's combined silhouettes.
  std::vector<std::vector<geometry::Pose>> joint_starts(bones);
  std::vector<std::vector<geometry::Pose>> part_joint_starts(bones);
  // Per bone, distances from the source that region matches suggest (for edge matching).
  std::vector<std::vector<double>> depth_hints(bones);
  // Both bones of a joint from the best matches of the joint's combined silhouettes to the
  // regions (camera-frame starts, with their mirrors, into `starts`).
  const auto jointMatchStarts = [&](const std::vector<imaging::ImplantBlob>& candidates,
                                    std::vector<std::vector<geometry::Pose>>* starts,
                                    std::vector<std::vector<double>>* depths) {
    struct JointStart {
      double dissimilarity;
      std::size_t joint;
      geometry::Pose parent;  // camera frame
      geometry::Pose child;
    };
    std::vector<JointStart> found_joints;
    for (const JointLibrary& jl : joint_libraries_) {
      for (const auto& blob : candidates) {
        for (const auto& match :
             jl.library->match(blob, 2, settings_.roll_step_deg,
                               imaging::SilhouetteLibrary::kShapeMinSeparationDeg, threads)) {
          if (const auto parent =
                  plausibleMatchPose(*jl.library, match, blob, first.camera, settings_)) {
            found_joints.push_back(
                {match.dissimilarity, jl.joint, *parent, *parent * jl.child_in_parent});
          }
        }
      }
    }
    std::sort(
        found_joints.begin(), found_joints.end(),
        [](const JointStart& a, const JointStart& b) { return a.dissimilarity < b.dissimilarity; });
    for (std::size_t k = 0;
         k < found_joints.size() && static_cast<int>(k) < settings_.joint_matches; ++k) {
      const JointStart& js = found_joints[k];
      const JointModel& joint = registrar_->joints()[js.joint];
      if (depths != nullptr) {
        (*depths)[joint.parent].push_back(js.parent.translation().z());
        (*depths)[joint.child].push_back(js.child.translation().z());
      }
      for (const double depth_factor : {1.0, 0.93}) {
        geometry::Pose parent = js.parent;
        geometry::Pose child = js.child;
        parent.translation() *= depth_factor;
        child.translation() *= depth_factor;
        addStart(&(*starts)[joint.parent], parent);
        addStart(&(*starts)[joint.child], child);
      }
    }
  };
  jointMatchStarts(regions, &joint_starts, &depth_hints);
  if (!neck_parts.empty()) jointMatchStarts(neck_parts, &part_joint_starts, nullptr);
  // Bone b's shape matches to the candidates, each at a few distances (returned as matched).
  const auto addShapeStarts =
      [&](std::size_t b, const std::vector<imaging::ImplantBlob>& candidates,
          std::vector<geometry::Pose>* starts, std::vector<std::size_t>* best_regions = nullptr) {
        const std::vector<geometry::Pose> shape_starts = shapeMatchStarts(
            *libraries_[b], candidates, first.camera, settings_, threads, best_regions);
        for (const geometry::Pose& camera_pose : shape_starts) {
          for (const double depth_factor : {1.0, 0.93, 0.86}) {
            geometry::Pose scaled = camera_pose;
            scaled.translation() *= depth_factor;
            addStart(starts, scaled);
          }
        }
        return shape_starts;
      };
  // The distance from the source of bone b's joint partners' best-fitting hypothesis, if one
  // fits at the suspect inlier fraction; 0 otherwise.
  const auto partnerDepth = [&](std::size_t b) {
    double depth = 0.0;
    double support = suspect_fraction;
    for (const JointModel& joint : registrar_->joints()) {
      const int partner = joint.parent == static_cast<int>(b)  ? joint.child
                          : joint.child == static_cast<int>(b) ? joint.parent
                                                               : -1;
      if (partner < 0) continue;
      for (const Hypothesis& h : hypotheses[static_cast<std::size_t>(partner)]) {
        if (h.support < support) continue;
        support = h.support;
        depth = (camera_from_world * h.pose.translation()).z();
      }
    }
    return depth;
  };
  // The coarse map's chamfer distances, the same for every bone and distance matched.
  const bool edge_matching = settings_.edge_matching && !regions.empty();
  const cv::Mat edge_distance =
      edge_matching ? coarse.unsignedDistance(kChamferTruncationPx) : cv::Mat();
  for (std::size_t b = 0; b < bones; ++b) {
    std::vector<geometry::Pose> starts = joint_starts[b];
    std::vector<std::size_t> best_shape_regions;
    const std::vector<geometry::Pose> shape_starts =
        addShapeStarts(b, regions, &starts, &best_shape_regions);
    if (edge_matching) {
      for (std::size_t k = 0; k < shape_starts.size() && k < 2; ++k) {
        depth_hints[b].push_back(shape_starts[k].translation().z());
      }
    }
    const auto edgeStarts = [&](const std::vector<double>& factors,
                                const std::vector<double>& depths,
                                const std::vector<std::size_t>& also_regions) {
      std::vector<geometry::Pose> edge_starts;
      if (!edge_matching) return edge_starts;
      for (const geometry::Pose& camera_pose :
           edgeMatchStarts(*libraries_[b], regions, also_regions, coarse, edge_distance, depths,
                           factors, settings_, threads)) {
        addStart(&edge_starts, camera_pose);
      }
      return edge_starts;
    };
    const std::vector<geometry::Pose> edge_starts =
        edgeStarts(settings_.edge_match_depth_factors, depth_hints[b], {});
    if (!seeds.empty() && geometry::isValidPose(seeds[b])) starts.push_back(seeds[b]);
    refineBest(b, starts);
    // Refined apart: chamfer matches fit edges by construction, so on a cluttered frame they
    // would outscore the region matches in screening and crowd them out (real Kneel frames).
    refineBest(b, edge_starts);
    // Nearer only for a bone still found poorly (PoseSearchSettings::
    // edge_match_nearer_depth_factors): for every bone they doubled the chamfer matching's time.
    if (foundPoorly(b))
      refineBest(b, edgeStarts(settings_.edge_match_nearer_depth_factors, depth_hints[b], {}));
    // At a joint partner's distance, for a bone still found poorly whose regions hint another:
    // the bones of a joint lie at nearly the same distance from the source, and a partner found
    // well knows it better than a region that a wire has spoiled. Around the bone's best-matching
    // regions as well: the largest may be a platform's or a table's bands.
    const double partner_gap = settings_.edge_match_partner_depth_gap;
    if (partner_gap > 0.0 && edge_matching && foundPoorly(b)) {
      const double partner_depth = partnerDepth(b);
      const double hinted = depth_hints[b].empty() ? 0.0 : median(depth_hints[b]);
      if (partner_depth > 0.0 && !(std::abs(hinted / partner_depth - 1.0) <= partner_gap)) {
        refineBest(
            b, edgeStarts(settings_.edge_match_depth_factors, {partner_depth}, best_shape_regions));
      }
    }
    if (!neck_parts.empty()) {
      std::vector<geometry::Pose> part_starts = part_joint_starts[b];
      addShapeStarts(b, neck_parts, &part_starts);
      refineBest(b, part_starts);
    }
  }

  // The rotation about a bone's long axis (mesh Y in the ISB frame) is what a silhouette shows
  // least (a tibial tray spun about its stem looks much the same): each bone's best
  // hypotheses are also tried spun about it.
  for (std::size_t b = 0; b < bones; ++b) {
    std::vector<Hypothesis> best = hypotheses[b];
    std::sort(best.begin(), best.end(),
              [](const Hypothesis& x, const Hypothesis& y) { return x.support > y.support; });
    best.resize(std::min<std::size_t>(best.size(), 2));
    std::vector<geometry::Pose> starts;
    for (const Hypothesis& h : best) {
      for (const double spin_deg : {-30.0, -15.0, 15.0, 30.0, 180.0}) {
        geometry::Pose spun = h.pose;
        spun.linear() = h.pose.linear() *
                        Eigen::AngleAxisd(geometry::degToRad(spin_deg), Eigen::Vector3d::UnitY())
                            .toRotationMatrix();
        starts.push_back(spun);
      }
    }
    refineBest(b, starts);
  }

  // 2. Each bone is also searched where its joint allows it to be, from each well-found
  // neighbour: across the flexion range of the joint's envelope (for a bone the image alone
  // finds poorly: merged with its neighbour's silhouette in flexion, occluded, cut by the
  // field's edge), and each of its own hypotheses moved into the envelope.
  // The missing bone's pose where `known` (the other bone's pose) and the joint put it.
  const auto throughJoint = [](const geometry::Pose& known, const geometry::Pose& child_in_parent,
                               bool child_missing) {
    return child_missing ? known * child_in_parent : known * child_in_parent.inverse();
  };
  for (std::size_t j = 0; j < registrar_->joints().size(); ++j) {
    const JointModel& joint = registrar_->joints()[j];
    for (const bool child_missing : {true, false}) {
      const std::size_t missing = child_missing ? joint.child : joint.parent;
      const std::size_t known = child_missing ? joint.parent : joint.child;
      if (hypotheses[known].empty()) continue;
      std::vector<geometry::Pose> starts;
      for (const Hypothesis& h : hypotheses[known]) {
        if (h.support < suspect_fraction) continue;
        for (const geometry::Pose& child_in_parent : envelope_[j]) {
          starts.push_back(throughJoint(h.pose, child_in_parent, child_missing));
        }
        // Each hypothesis of the other bone moved into the envelope: a rotation about a nearly
        // symmetric implant's axis that its silhouette cannot show is taken from the joint.
        for (const Hypothesis& other : hypotheses[missing]) {
          const geometry::Pose& parent = child_missing ? h.pose : other.pose;
          const geometry::Pose& child = child_missing ? other.pose : h.pose;
          const kinematics::KneeCoordinates k =
              clampedToEnvelope(joint.ligaments, envelopeCoordinates(joint, parent, child));
          starts.push_back(jointPartner(joint, h.pose, k, child_missing));
        }
      }
      // A bone that no hypothesis fits yet (merged with its neighbour's silhouette, whose
      // envelope starts a wrong flexion can outscore: the femoral component's round condyles
      // stay on their edges as it turns about them) has only these starts to be found from.
      refineBest(missing, starts, foundPoorly(missing) ? settings_.envelope_extra_refined : 0);
    }
  }
  // ... and a bone still found poorly, beside a neighbour found well, from that neighbour and its
  // reflections across the beam through the finer envelope (PoseSearchSettings::fine_envelope).
  for (std::size_t j = 0; settings_.fine_envelope && j < registrar_->joints().size(); ++j) {
    const JointModel& joint = registrar_->joints()[j];
    for (const bool child_missing : {true, false}) {
      const std::size_t missing = child_missing ? joint.child : joint.parent;
      const std::size_t known = child_missing ? joint.parent : joint.child;
      if (!foundPoorly(missing)) continue;
      std::vector<geometry::Pose> starts;
      for (const Hypothesis& h : hypotheses[known]) {
        if (h.support < settings_.fine_envelope_neighbour_inliers) continue;
        // A neighbour seen nearly edge-on fits as well reflected (a tray's tilt), and the
        // missing bone sits by the true one.
        const geometry::Pose in_camera = camera_from_world * h.pose;
        const std::vector<geometry::Pose>& fine_samples = fineEnvelope()[j];
        for (const geometry::Pose& neighbour :
             {h.pose, world_from_camera * tiltReflectedAcrossBeam(in_camera),
              world_from_camera * turnReflectedAcrossBeam(in_camera),
              world_from_camera * mirroredAcrossBeam(in_camera)}) {
          for (const geometry::Pose& child_in_parent : fine_samples) {
            starts.push_back(throughJoint(neighbour, child_in_parent, child_missing));
          }
        }
      }
      if (!starts.empty()) refineBest(missing, starts, settings_.envelope_extra_refined);
    }
  }
  for (std::size_t b = 0; b < bones; ++b) {
    if (hypotheses[b].empty()) {
      throw InputError("pose search: no pose of bone '" + registrar_->bones()[b].name +
                       "' fits the image (" + std::to_string(blobs.size()) +
                       " candidate region(s) found)");
    }
  }

  // 3. The combinations that best explain the image inside the joints' envelopes (exhaustive
  // over the few hypotheses per bone); the best few are registered jointly, with the joints'
  // contact and ligament terms, and the result that best explains the image inside the
  // envelopes wins: a wrong hypothesis pulled into the envelope loses its image support.
  std::vector<std::pair<double, std::vector<std::size_t>>> combinations;
  std::vector<std::size_t> choice(bones, 0);
  while (true) {
    double score = 0.0;
    std::vector<geometry::Pose> poses(bones);
    for (std::size_t b = 0; b < bones; ++b) {
      poses[b] = hypotheses[b][choice[b]].pose;
      score += hypotheses[b][choice[b]].support;
    }
    for (const JointModel& joint : registrar_->joints()) {
      const geometry::Pose& parent = poses[joint.parent];
      const geometry::Pose& child = poses[joint.child];
      score -= jointPenalty(
          joint.ligaments.enabled ? joint.envelopeViolation(parent, child) : 0.0,
          joint.contact ? joint.contact->sampledFigures(parent, child).max_depth_m : 0.0);
    }
    combinations.emplace_back(score, choice);
    std::size_t b = 0;
    while (b < bones && ++choice[b] == hypotheses[b].size()) choice[b++] = 0;
    if (b == bones) break;
  }
  std::sort(combinations.begin(), combinations.end(),
            [](const auto& x, const auto& y) { return x.first > y.first; });
  double best_score = -std::numeric_limits<double>::infinity();
  const std::size_t finalists =
      std::min<std::size_t>(combinations.size(), static_cast<std::size_t>(settings_.finalists));
  for (std::size_t c = 0; c < finalists; ++c) {
    std::vector<geometry::Pose> poses(bones);
    for (std::size_t b = 0; b < bones; ++b) {
      poses[b] = hypotheses[b][combinations[c].second[b]].pose;
    }
    RegistrationResult registered;
    try {
      registered = registrar_->solve(views, poses);
    } catch (const InputError&) {
      continue;
    }
    const double score = finalistScore(registered);
    if (score > best_score) {
      best_score = score;
      found.registration = std::move(registered);
    }
  }
  if (found.registration.poses.empty()) {
    throw InputError("pose search: no combination of the bones' hypotheses could be registered");
  }
  found.score = best_score;
  found.status = classifyBones(found.registration, registrar_->settings().quality);
  return found;
}

}  // namespace registration
}  // namespace fluoro_tracker
