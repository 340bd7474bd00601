#include "fluoro_tracker/registration/pose_search.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace registration {
namespace {

// A bone's pose that one start refined to, and how well the image supports it.
struct Hypothesis {
  geometry::Pose pose;
  double support = 0.0;  // contour inlier fraction
};

// The pose of a bone mirrored through the plane across the beam (optical z) at its origin, for
// an implant symmetric about its sagittal plane (mesh X-Y, the ISB frame's): the same silhouette
// in orthographic projection, so the pose a single view cannot tell from the original.
geometry::Pose mirroredAcrossBeam(const geometry::Pose& camera_from_mesh) {
  const Eigen::Matrix3d flip = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  geometry::Pose mirrored = camera_from_mesh;
  mirrored.linear() = flip * camera_from_mesh.linear() * flip;
  return mirrored;
}

bool isSameHypothesis(const geometry::Pose& a, const geometry::Pose& b) {
  return (a.translation() - b.translation()).norm() < 2e-3 &&
         geometry::rotationAngleBetween(a.linear(), b.linear()) < 2.0 * 3.14159265358979 / 180.0;
}

// The image's starting poses for one bone (camera frame): the best shape matches over all
// regions, each with the pose its region's size and place imply.
std::vector<geometry::Pose> shapeMatchStarts(const imaging::SilhouetteLibrary& library,
                                             const std::vector<imaging::ImplantBlob>& blobs,
                                             const geometry::XrayCamera& camera,
                                             const PoseSearchSettings& settings) {
  const int count = settings.matches_per_bone;
  struct Start {
    double dissimilarity;
    geometry::Pose pose;
  };
  std::vector<Start> starts;
  for (const auto& blob : blobs) {
    for (const auto& match : library.match(blob, count, settings.roll_step_deg)) {
      const geometry::Pose pose = library.cameraFromMesh(match, blob, camera);
      const double depth = pose.translation().z();
      if (pose.translation().allFinite() && depth >= settings.min_depth_m &&
          depth <= settings.max_depth_m) {
        starts.push_back({match.dissimilarity, pose});
      }
    }
  }
  std::sort(starts.begin(), starts.end(),
            [](const Start& a, const Start& b) { return a.dissimilarity < b.dissimilarity; });
  std::vector<geometry::Pose> poses;
  for (std::size_t k = 0; k < starts.size() && static_cast<int>(k) < count; ++k) {
    poses.push_back(starts[k].pose);
  }
  return poses;
}

// How well a pose's projected contour lies on the coarse map's edges: the share of contour
// samples within one coarse pixel of an edge (0 when the bone is not in the view).
double screeningScore(const imaging::SilhouetteModel& silhouette, const geometry::Pose& pose,
                      const imaging::EdgeMap& coarse) {
  const geometry::XrayCamera& camera = coarse.camera();
  const geometry::Pose camera_from_mesh = camera.worldFromCamera().inverse() * pose;
  if (camera_from_mesh.translation().z() <= 0.0) return 0.0;
  const auto contour = silhouette.contour(camera, camera_from_mesh, 1.0);
  if (contour.empty()) return 0.0;
  int near = 0;
  for (const auto& c : contour) {
    double d = 0.0;
    double du = 0.0;
    double dv = 0.0;
    if (coarse.sample(c.pixel.x(), c.pixel.y(), &d, &du, &dv) && std::abs(d) <= 1.0) ++near;
  }
  return static_cast<double>(near) / contour.size();
}

// The pose of the missing bone of a joint for given joint coordinates and the other's pose.
geometry::Pose jointPartner(const JointModel& joint, const geometry::Pose& known,
                            const kinematics::KneeCoordinates& k, bool child_missing) {
  // The child's anatomical frame in the parent's.
  const geometry::Pose relative =
      kinematics::tibiaFromKneeCoordinates(geometry::Pose::Identity(), k, joint.side);
  if (child_missing) {
    return known * joint.parent_anatomical * relative * joint.child_anatomical.inverse();
  }
  return known * joint.child_anatomical * relative.inverse() * joint.parent_anatomical.inverse();
}

// Starting poses of one bone of a knee from the other's pose: across the envelope's flexion
// range in 10 degree steps, every other coordinate at the middle of its bounds; an unbounded
// distraction is set where the articular surfaces touch (when the joint has contact
// surfaces), since that is where a loaded knee is.
std::vector<geometry::Pose> envelopeStarts(const JointModel& joint, const geometry::Pose& known,
                                           bool child_missing) {
  const auto& bounds = joint.ligaments.bounds;
  const auto middle = [](const constraints::CoordinateBounds& b) {
    return std::isfinite(b.lower) && std::isfinite(b.upper) ? 0.5 * (b.lower + b.upper) : 0.0;
  };
  constexpr double kRadPerDeg = 3.14159265358979323846 / 180.0;
  const double lowest = std::isfinite(bounds[0].lower) ? bounds[0].lower : -10.0;
  const double highest = std::isfinite(bounds[0].upper) ? bounds[0].upper : 150.0;
  const bool free_distraction = !std::isfinite(bounds[4].lower) || !std::isfinite(bounds[4].upper);
  // Anterior-posterior translation: its bounds in 10 mm steps (the envelope is wide in it).
  std::vector<double> anterior_mm = {middle(bounds[3])};
  if (std::isfinite(bounds[3].lower) && std::isfinite(bounds[3].upper)) {
    anterior_mm.clear();
    for (double x = bounds[3].lower; x <= bounds[3].upper + 1e-9; x += 10.0)
      anterior_mm.push_back(x);
  }
  std::vector<geometry::Pose> starts;
  for (double flexion = lowest; flexion <= highest + 1e-9; flexion += 10.0) {
    for (double x_mm : anterior_mm) {
      kinematics::KneeCoordinates k;
      k.flexion_rad = flexion * kRadPerDeg;
      k.adduction_rad = middle(bounds[1]) * kRadPerDeg;
      k.internal_rotation_rad = middle(bounds[2]) * kRadPerDeg;
      k.x_m = x_mm * 1e-3;
      k.y_m = middle(bounds[4]) * 1e-3;
      k.z_m = middle(bounds[5]) * 1e-3;
      geometry::Pose partner = jointPartner(joint, known, k, child_missing);
      if (free_distraction && joint.contact) {
        // Move the tibia along the femur's long axis by the signed gap until the surfaces touch.
        for (int iteration = 0; iteration < 8; ++iteration) {
          const geometry::Pose& parent = child_missing ? known : partner;
          const geometry::Pose& child = child_missing ? partner : known;
          const double gap = joint.contact->figures(parent, child, false).min_distance_m;
          if (!std::isfinite(gap) || std::abs(gap) < 2e-4) break;
          k.y_m += std::clamp(gap, -0.03, 0.03);
          partner = jointPartner(joint, known, k, child_missing);
        }
      }
      starts.push_back(partner);
    }
  }
  return starts;
}

}  // namespace

void PoseSearchSettings::validate() const {
  if (!(direction_step_deg > 1.0 && direction_step_deg < 90.0)) {
    throw InputError("registration search: direction_step_deg must be in (1, 90)");
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
  if (!(screening_scale > 0.0 && screening_scale <= 1.0)) {
    throw InputError("registration search: screening_scale must be in (0, 1]");
  }
  if (refine_scales.empty()) throw InputError("registration search: refine_scales is empty");
  if (!(refine_robust_scale_px > 0.0)) {
    throw InputError("registration search: refine_robust_scale_px must be > 0");
  }
  for (double s : refine_scales) {
    if (!(s > 0.0 && s <= 1.0)) throw InputError("registration search: refine_scales in (0, 1]");
  }
  if (!(envelope_penalty_per_unit >= 0.0) || !(penetration_penalty_per_mm >= 0.0)) {
    throw InputError("registration search: penalties must be >= 0");
  }
  if (blobs.threshold_fractions.empty() || blobs.working_size_px < 32) {
    throw InputError("registration search: blobs need thresholds and working_size_px >= 32");
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
  // Starts are several pixels off at the coarsest scale: a wider robust kernel keeps their
  // edges in the basin (the final joint registration uses the trial's own settings).
  refine.robust_scale_px = std::max(refine.robust_scale_px, settings_.refine_robust_scale_px);
  // Shape matching is good to tens of millimetres along the beam and a view step in angle.
  refine.max_translation_from_start_m = std::max(refine.max_translation_from_start_m, 0.1);
  refine.max_rotation_from_start_rad = std::max(refine.max_rotation_from_start_rad, 0.8);
  for (const auto& bone : registrar_->bones()) {
    libraries_.push_back(std::make_unique<imaging::SilhouetteLibrary>(
        bone.silhouette->mesh(), settings_.direction_step_deg));
    refiners_.push_back(std::make_unique<Registrar>(std::vector<BoneModel>{bone}, refine));
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
  const ViewImage& first = views.front();
  const std::vector<imaging::ImplantBlob> blobs =
      imaging::findImplantBlobs(first.image, settings_.blobs);
  PoseSearchResult found;
  found.regions = static_cast<int>(blobs.size());
  const imaging::EdgeMap coarse(first.image, first.camera, registrar_->settings().edges, cv::Rect(),
                                settings_.screening_scale);

  // Screens starts on the coarse edge map and refines the best few, one bone at a time.
  std::vector<std::vector<Hypothesis>> hypotheses(bones);
  const auto refineBest = [&](std::size_t b, std::vector<geometry::Pose> starts) {
    std::vector<std::pair<double, geometry::Pose>> screened;
    for (const geometry::Pose& s : starts) {
      screened.emplace_back(screeningScore(*registrar_->bones()[b].silhouette, s, coarse), s);
    }
    std::stable_sort(screened.begin(), screened.end(),
                     [](const auto& x, const auto& y) { return x.first > y.first; });
    std::vector<geometry::Pose> refined_starts;
    for (const auto& [score, pose] : screened) {
      if (static_cast<int>(refined_starts.size()) >= settings_.refined_per_bone) break;
      const bool distinct =
          std::none_of(refined_starts.begin(), refined_starts.end(),
                       [&](const geometry::Pose& other) { return isSameHypothesis(other, pose); });
      if (distinct) refined_starts.push_back(pose);
    }
    for (const geometry::Pose& s : refined_starts) {
      RegistrationResult refined;
      try {
        refined = refiners_[b]->solve(views, {s});
      } catch (const InputError&) {
        continue;  // a start behind the source or outside the views: not a hypothesis
      }
      ++found.hypotheses;
      if (refined.diverged[0] || !geometry::isValidPose(refined.poses[0])) continue;
      const Hypothesis h{refined.poses[0], refined.quality[0].contour_inlier_fraction};
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
  const auto bestSupport = [&](std::size_t b) {
    double best = 0.0;
    for (const Hypothesis& h : hypotheses[b]) best = std::max(best, h.support);
    return best;
  };

  // 1. Each bone on its own: shape matches of the image's regions, mirrored, at a few
  // distances (a region thresholded from a blurred rim is smaller than the silhouette).
  for (std::size_t b = 0; b < bones; ++b) {
    std::vector<geometry::Pose> starts;
    for (const geometry::Pose& camera_pose :
         shapeMatchStarts(*libraries_[b], blobs, first.camera, settings_)) {
      for (const double depth_factor : {1.0, 0.93, 0.86}) {
        geometry::Pose scaled = camera_pose;
        scaled.translation() *= depth_factor;
        starts.push_back(first.camera.worldFromCamera() * scaled);
        if (settings_.mirror_hypotheses) {
          starts.push_back(first.camera.worldFromCamera() * mirroredAcrossBeam(scaled));
        }
      }
    }
    if (!seeds.empty() && geometry::isValidPose(seeds[b])) starts.push_back(seeds[b]);
    refineBest(b, starts);
  }

  // 2. A bone the image alone did not find well (merged with its neighbour's silhouette in
  // flexion, occluded, or cut by the field's edge) is searched where its joint allows it to be:
  // across the flexion range of the joint's envelope, from each well-found neighbour.
  for (const JointModel& joint : registrar_->joints()) {
    for (const bool child_missing : {true, false}) {
      const std::size_t missing = child_missing ? joint.child : joint.parent;
      const std::size_t known = child_missing ? joint.parent : joint.child;
      const double threshold = registrar_->settings().quality.suspect_inlier_fraction;
      if (bestSupport(missing) >= threshold || hypotheses[known].empty()) continue;
      std::vector<geometry::Pose> starts;
      for (const Hypothesis& h : hypotheses[known]) {
        if (h.support < threshold) continue;
        for (const geometry::Pose& p : envelopeStarts(joint, h.pose, child_missing)) {
          starts.push_back(p);
        }
      }
      refineBest(missing, starts);
    }
  }
  for (std::size_t b = 0; b < bones; ++b) {
    if (hypotheses[b].empty()) {
      throw InputError("pose search: no pose of bone '" + registrar_->bones()[b].name +
                       "' fits the image (" + std::to_string(blobs.size()) +
                       " candidate region(s) found)");
    }
  }

  // 3. The combination that best explains the image inside the joints' envelopes: exhaustive
  // over the (few) hypotheses per bone.
  std::vector<std::size_t> choice(bones, 0);
  std::vector<std::size_t> best_choice = choice;
  double best_score = -std::numeric_limits<double>::infinity();
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
      if (joint.ligaments.enabled) {
        score -= settings_.envelope_penalty_per_unit *
                 envelopeViolation(joint.ligaments, joint.coordinates(parent, child));
      }
      if (joint.contact) {
        score -= settings_.penetration_penalty_per_mm * 1e3 *
                 joint.contact->figures(parent, child, false).max_depth_m;
      }
    }
    if (score > best_score) {
      best_score = score;
      best_choice = choice;
    }
    std::size_t b = 0;
    while (b < bones && ++choice[b] == hypotheses[b].size()) choice[b++] = 0;
    if (b == bones) break;
  }
  std::vector<geometry::Pose> chosen(bones);
  for (std::size_t b = 0; b < bones; ++b) chosen[b] = hypotheses[b][best_choice[b]].pose;
  found.registration = registrar_->solve(views, chosen);
  found.status = classifyBones(found.registration, registrar_->settings().quality);
  found.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return found;
}

}  // namespace registration
}  // namespace fluoro_tracker
