#include "fluoro_tracker/registration/tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <optional>

#include "fluoro_tracker/imaging/featureless_frame.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/median.h"
#include "fluoro_tracker/parallel_for.h"
#include "fluoro_tracker/registration/image_shift_search.h"
#include "fluoro_tracker/registration/motion_prediction.h"

namespace fluoro_tracker {
namespace registration {

namespace {

// The history behind the retry of a bone that fits worse than recently (fitsWorseThanRecently):
// the fractions counted where the outline lies, compared from the first frame on. Why from the
// first: a trial's second frame has no velocity to predict from, so a knee moving a few
// millimetres per frame starts it that far off, and a registration at full resolution alone
// can settle there on a wrong pose that still fits most of the outline (a step-down seen with
// low dose and blur, 3.4 mm per frame: the femoral component 3.7 deg about its first axis at
// 0.83 of its outline against 0.99 in frame 0, status ok). With the three frames the status's
// history waits for, those wrong frames had become the history's median by then, and the knee
// drifted 12 mm along the beam over five frames before it came back.
QualitySettings whereTheOutlineLies(QualitySettings settings) {
  settings.inliers_at_edge_offset = false;
  settings.relative_inlier_min_frames = 1;
  return everySampleCounted(settings);  // a decision (see accept())
}

// Wall time since `start`, in seconds.
double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Why the frame shows nothing when no view shows anything ("the frame shows one grey level", or
// with several views "no view shows anything (view 1: ...; view 2: ...)", see
// imaging::featurelessFrame); empty when some view shows something.
std::string featurelessViews(const std::vector<ViewImage>& views, double max_ratio) {
  std::string shown;
  for (std::size_t v = 0; v < views.size(); ++v) {
    const std::string nothing = imaging::featurelessFrame(views[v].image, max_ratio);
    if (nothing.empty()) return {};
    if (views.size() == 1) return "the frame shows " + nothing;
    shown += (v == 0 ? "" : "; ") + ("view " + std::to_string(v + 1) + ": ") + nothing;
  }
  return "no view shows anything (" + shown + ")";
}

}  // namespace

std::string describeImplausibleJumps(const TrackedFrame& frame,
                                     const std::vector<BoneModel>& bones) {
  std::string names;
  for (std::size_t b = 0; b < frame.implausible_jump.size() && b < bones.size(); ++b) {
    if (frame.implausible_jump[b]) names += (names.empty() ? "" : ", ") + bones[b].name;
  }
  if (names.empty()) return names;
  return "the search found " + names +
         " farther from the last good pose than a bone moves in the frames since (a frame "
         "showing another knee, or this one mirrored?): kept lost there";
}

Tracker::Tracker(std::shared_ptr<const Registrar> registrar, std::vector<geometry::Pose> initial,
                 std::shared_ptr<const PoseSearch> search)
    : registrar_(std::move(registrar)),
      search_(std::move(search)),
      poses_(std::move(initial)),
      edge_offsets_(
          registrar_ ? registrar_->settings().edge_offset_tracking : EdgeOffsetTrackingSettings(),
          registrar_ ? registrar_->settings().edge_offset_prior_px : 0.0),
      inlier_history_(
          everySampleCounted(registrar_ ? registrar_->settings().quality : QualitySettings())),
      reported_history_(registrar_ ? registrar_->settings().quality : QualitySettings()),
      outline_history_(
          whereTheOutlineLies(registrar_ ? registrar_->settings().quality : QualitySettings())) {
  if (!registrar_) throw InputError("tracker: no registrar");
  if (poses_.empty() && !search_) {
    throw InputError("tracker: no initial poses and no automatic search to find them");
  }
  if (!poses_.empty() && poses_.size() != registrar_->bones().size()) {
    throw InputError("tracker: " + std::to_string(poses_.size()) + " initial pose(s) for " +
                     std::to_string(registrar_->bones().size()) + " bone(s)");
  }
  for (std::size_t b = 0; b < poses_.size(); ++b) {
    if (!geometry::isValidPose(poses_[b])) {
      throw InputError("tracker: the initial pose of bone '" + registrar_->bones()[b].name +
                       "' is not a finite rigid transform");
    }
  }
  continuing_registrar_ = registrar_;
  retrying_registrar_ = registrar_;
  const RegistrationSettings& settings = registrar_->settings();
  const bool tracking_margin_differs =
      settings.tracking_inner_edge_margin_px != settings.inner_edge_margin_px;
  if (tracking_margin_differs) {
    RegistrationSettings retrying = settings;
    retrying.inner_edge_margin_px = settings.tracking_inner_edge_margin_px;
    retrying_registrar_ =
        std::make_shared<const Registrar>(registrar_->bones(), retrying, registrar_->joints());
  }
  if (settings.mirror_check.enabled || settings.tracking_scales != settings.scales ||
      settings.depth_retry.enabled || settings.reflection_retry.enabled ||
      settings.rotation_retry.enabled || tracking_margin_differs) {
    RegistrationSettings continuing = settings;
    // A continued frame starts near its answer; a lost one is searched (see track()).
    continuing.depth_retry.enabled = false;
    continuing.reflection_retry.enabled = false;
    // Only for a bone whose spread rose above its recent frames' (see recentSpreads()).
    continuing.rotation_retry.enabled =
        settings.rotation_retry.enabled && settings.rotation_retry.tracking_spread_rise > 0.0;
    // Only the turn (and tilt) reflection, and only near the view where the branches meet (see
    // MirrorCheckSettings::tracking_turn_max_difference_deg).
    const MirrorCheckSettings& mirror = settings.mirror_check;
    continuing.mirror_check.tilt_reflection =
        mirror.tilt_reflection && mirror.tracking_tilt_reflection;
    continuing.mirror_check.enabled =
        mirror.enabled && (mirror.turn_reflection || continuing.mirror_check.tilt_reflection) &&
        mirror.tracking_turn_max_difference_deg > mirror.min_difference_deg;
    continuing.mirror_check.mirror_reflection = false;
    // Where the branches meet, the two lie within a few degrees and are nearly equally neutral
    // by construction: the check keeps the tracker on the nearer-neutral one without a margin.
    continuing.mirror_check.min_neutral_gain = 0.0;
    if (continuing.mirror_check.enabled) {
      continuing.mirror_check.max_difference_deg =
          std::min(mirror.max_difference_deg, mirror.tracking_turn_max_difference_deg);
    }
    continuing.scales = settings.tracking_scales;
    continuing.inner_edge_margin_px = settings.tracking_inner_edge_margin_px;
    continuing_registrar_ =
        std::make_shared<const Registrar>(registrar_->bones(), continuing, registrar_->joints());
  }
}

void Tracker::reinitialize(const std::vector<std::string>& bones,
                           const std::vector<geometry::Pose>& poses) {
  if (bones.size() != poses.size()) {
    throw InputError("reinitialize: " + std::to_string(bones.size()) + " bone name(s) but " +
                     std::to_string(poses.size()) + " pose(s)");
  }
  if (poses_.empty() && bones.size() != registrar_->bones().size()) {
    throw InputError("reinitialize: the tracker has no poses yet; give every bone's pose");
  }
  std::vector<geometry::Pose> updated =
      poses_.empty() ? std::vector<geometry::Pose>(registrar_->bones().size()) : poses_;
  for (std::size_t k = 0; k < bones.size(); ++k) {
    const auto& all = registrar_->bones();
    std::size_t b = 0;
    while (b < all.size() && all[b].name != bones[k]) ++b;
    if (b == all.size()) throw InputError("reinitialize: no bone named '" + bones[k] + "'");
    if (!geometry::isValidPose(poses[k])) {
      throw InputError("reinitialize: the pose of bone '" + bones[k] +
                       "' is not a finite rigid transform");
    }
    updated[b] = geometry::normalized(poses[k]);
  }
  poses_ = updated;
  previous_.clear();
  recovering_ = false;
  search_requested_ = false;
  last_ok_.clear();
  frames_since_ok_.clear();
  poses_registered_ = false;
  previous_trouble_ = 0;
  previous_all_ok_ = false;
  restart_after_doubt_.clear();
}

void Tracker::requestSearch() {
  if (!search_) throw InputError("tracker: automatic search is not configured");
  recovering_ = true;
  search_requested_ = true;
}

TrackedFrame Tracker::searchAndReset(const std::vector<ViewImage>& views) {
  if (!search_) throw InputError("tracker: automatic search is not configured");
  const auto start = std::chrono::steady_clock::now();
  PoseSearchResult found = search_->search(views, poses_);
  TrackedFrame frame;
  frame.searched = true;
  frame.result = std::move(found.registration);
  frame.status = classifyBones(frame.result, everySampleCounted(registrar_->settings().quality));
  frame.poses = frame.result.poses;
  frame.solve_seconds = secondsSince(start);
  if (search_requested_) {
    search_requested_ = false;
  } else {
    rejectImplausibleJumps(&frame);
  }
  accept(&frame);
  return frame;
}

void Tracker::rejectImplausibleJumps(TrackedFrame* frame) const {
  const RegistrationSettings& settings = registrar_->settings();
  frame->implausible_jump.assign(frame->poses.size(), false);
  for (std::size_t b = 0; b < frame->poses.size(); ++b) {
    // Only against a pose a registration called ok: a user's guess may be centimetres off, and
    // a suspect pose may be the very jump (a mirrored tray that fits, beside a femur that does
    // not).
    if (frame->status[b] == "lost" || b >= last_ok_.size() || !last_ok_[b]) continue;
    if (!withinMotionLimits(*last_ok_[b], frame->poses[b], settings, 1 + frames_since_ok_[b])) {
      frame->implausible_jump[b] = true;
      frame->status[b] = "lost";
    }
  }
}

bool Tracker::jointPartnersOk(const std::vector<std::string>& status, std::size_t b) const {
  for (const JointModel& joint : registrar_->joints()) {
    const auto parent = static_cast<std::size_t>(joint.parent);
    const auto child = static_cast<std::size_t>(joint.child);
    const std::size_t partner = parent == b ? child : child == b ? parent : b;
    if (partner != b && partner < status.size() && status[partner] != "ok") return false;
  }
  return true;
}

TrackedFrame Tracker::giveUp(const std::string& reason) {
  TrackedFrame frame;
  frame.given_up = reason;
  frame.poses = poses_;
  frame.status.assign(poses_.size(), "lost");
  frame.result.poses = poses_;
  frame.result.diverged.assign(poses_.size(), true);
  // Time passes all the same: a bone may be that much farther from its last good pose by the
  // frame that finds it (rejectImplausibleJumps).
  for (int& frames : frames_since_ok_) ++frames;
  return frame;
}

void Tracker::accept(TrackedFrame* frame) {
  // The status reported leaves out the contour samples a view cannot show while the other views
  // hold the bone (QualitySettings::unseen_edge_distance_px); the tracker's own decisions, here
  // and in track(), count every sample, so that the rule changes what is reported, never a pose.
  std::vector<std::string> reported = classifyBones(frame->result, registrar_->settings().quality);
  for (std::size_t b = 0; b < reported.size() && b < frame->status.size(); ++b) {
    if (frame->status[b] == "lost") reported[b] = "lost";  // e.g. an implausible jump
  }
  // The next frame's retry compares its own quality figures' status with this one's, before
  // either is compared with the bone's recent frames.
  previous_trouble_ = statusTrouble(frame->status);
  outline_history_.record(frame->result.quality, frame->status);  // the same frames
  inlier_history_.classify(frame->result.quality, &frame->status);
  reported_history_.classify(frame->result.quality, &reported);
  const bool first = poses_.empty();
  bool all_ok = true;
  for (std::size_t b = 0; b < frame->poses.size(); ++b) {
    all_ok = all_ok && frame->status[b] == "ok";
    if (frame->status[b] == "lost" && !first) frame->poses[b] = poses_[b];
  }
  const bool any_lost =
      std::find(frame->status.begin(), frame->status.end(), "lost") != frame->status.end();
  std::vector<bool> usable(frame->status.size());
  for (std::size_t b = 0; b < usable.size(); ++b) usable[b] = frame->status[b] != "lost";
  edge_offsets_.update(frame->result.edge_offsets_px, usable);
  // A registered frame that leaves a bone suspect right after a frame with every bone ok: the
  // next frame is registered as well from where the bones would be had they gone on as before,
  // predicted from the poses before this frame (still in poses_) and the start this frame was
  // registered from (tracking_restart_after_suspect).
  restart_after_doubt_.clear();
  if (!all_ok && previous_all_ok_ && !first && !any_lost && !frame->searched) {
    restart_after_doubt_ = last_guess_.size() == poses_.size()
                               ? predictPoses(poses_, last_guess_, registrar_->joints(),
                                              registrar_->settings().tracking_prediction)
                               : poses_;
  }
  previous_all_ok_ = all_ok;
  // Velocity only from two good frames in a row; a lost bone restarts from its last good pose.
  previous_ = all_ok && !first && !frame->searched ? poses_ : std::vector<geometry::Pose>();
  if (!first || !any_lost) poses_ = frame->poses;
  if (first && any_lost) poses_.clear();  // not found yet: search again next frame
  // A search that leaves a bone in doubt has not brought tracking back: the next frame is
  // registered from these poses and searched again unless every bone is then ok.
  recovering_ = (any_lost || (frame->searched && !all_ok)) && search_ != nullptr;
  poses_registered_ = !poses_.empty();
  const std::size_t window =
      static_cast<std::size_t>(std::max(1, registrar_->settings().quality.relative_inlier_window));
  recent_spreads_.resize(frame->status.size());
  for (std::size_t b = 0; b < frame->status.size() && b < frame->result.quality.size(); ++b) {
    const double spread = frame->result.quality[b].contour_spread_px;
    if (frame->status[b] == "lost" || !std::isfinite(spread)) continue;
    recent_spreads_[b].push_back(spread);
    if (recent_spreads_[b].size() > window) recent_spreads_[b].pop_front();
  }
  last_ok_.resize(frame->status.size());
  frames_since_ok_.resize(frame->status.size(), 0);
  for (std::size_t b = 0; b < frame->status.size(); ++b) {
    // A bone called ok beside a joint partner in doubt may be the wrong one of the two (a tray
    // fitted to a rod beside a femoral component the search could not place): its pose is no
    // reference for rejectImplausibleJumps, which would then turn away the right pose found later.
    if (frame->status[b] == "ok" && jointPartnersOk(frame->status, b)) {
      last_ok_[b] = frame->poses[b];
      frames_since_ok_[b] = 0;
    } else {
      ++frames_since_ok_[b];
    }
  }
  frame->status = std::move(reported);
}

std::vector<bool> Tracker::fitsWorseThanRecently(const RegistrationResult& result,
                                                 std::size_t views) const {
  const double drop = registrar_->settings().tracking_retry_inlier_drop;
  std::vector<bool> worse(result.quality.size(), false);
  // A second view sees the depth that the edge offset trades against in one.
  if (!(drop > 0.0) || views != 1) return worse;
  for (std::size_t b = 0; b < worse.size(); ++b) {
    worse[b] =
        outline_history_.fallsBelowMedian(b, outline_history_.fractionOf(result.quality[b]), drop);
  }
  return worse;
}

std::vector<double> Tracker::recentSpreads() const {
  const std::size_t min_frames = static_cast<std::size_t>(
      std::max(1, registrar_->settings().quality.relative_inlier_min_frames));
  std::vector<double> medians(registrar_->bones().size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t b = 0; b < medians.size() && b < recent_spreads_.size(); ++b) {
    if (recent_spreads_[b].size() < min_frames) continue;
    medians[b] = median(std::vector<double>(recent_spreads_[b].begin(), recent_spreads_[b].end()));
  }
  return medians;
}

bool Tracker::fitsClearlyBetter(const RegistrationResult& retry, int retry_trouble,
                                const RegistrationResult& continued, int continued_trouble,
                                const std::vector<bool>& fits_worse) const {
  if (retry_trouble > continued_trouble || !(retry.final_cost < continued.final_cost)) {
    return false;
  }
  double gain = 0.0;
  for (std::size_t b = 0; b < fits_worse.size(); ++b) {
    if (fits_worse[b]) {
      gain +=
          retry.quality[b].contour_inlier_fraction - continued.quality[b].contour_inlier_fraction;
    }
  }
  return gain >= registrar_->settings().tracking_retry_min_inlier_gain;
}

bool Tracker::fitsAboutAsMuch(const RegistrationResult& retry, const RegistrationResult& continued,
                              const std::vector<std::string>& continued_status) const {
  const double max_loss = registrar_->settings().tracking_retry_max_inlier_loss;
  for (std::size_t b = 0; b < retry.quality.size() && b < continued.quality.size(); ++b) {
    // A lost bone's fraction says nothing (it may have diverged onto clutter).
    if (b < continued_status.size() && continued_status[b] == "lost") continue;
    if (retry.quality[b].contour_inlier_fraction <
        continued.quality[b].contour_inlier_fraction - max_loss) {
      return false;
    }
  }
  return true;
}

std::optional<TrackedFrame> Tracker::registeredFromLastGoodPoses(
    const std::vector<ViewImage>& views, const std::vector<bool>& loaded, double* seconds) {
  // The full schedule and mirror check, as from poses the user gave; every bone must be ok, its
  // recent frames' inlier history included (asked of a copy: nothing recorded for a frame not
  // taken).
  const auto start = std::chrono::steady_clock::now();
  TrackedFrame frame;
  try {
    frame.result = registrar_->solve(
        views, poses_, loaded, edge_offsets_.priors(registrar_->bones().size(), views.size()));
  } catch (const InputError&) {
    *seconds = secondsSince(start);
    return std::nullopt;
  }
  frame.status = classifyBones(frame.result, everySampleCounted(registrar_->settings().quality));
  std::vector<std::string> against_history = frame.status;
  InlierHistory(inlier_history_).classify(frame.result.quality, &against_history);
  *seconds = secondsSince(start);
  if (statusTrouble(against_history) > 0) return std::nullopt;
  frame.solve_seconds = *seconds;
  frame.poses = frame.result.poses;
  accept(&frame);
  return frame;
}

void Tracker::preferThePosesBeforeDoubt(const std::vector<ViewImage>& views,
                                        const std::vector<bool>& loaded,
                                        const EdgeOffsetPriors& priors, TrackedFrame* frame) const {
  // The last frame was the first in doubt: its poses may be a corrupted frame's (a tray turned
  // to fit a mirrored frame, at status ok beside a suspect femur), and a registration continued
  // from them would carry that side of the view's ambiguity on at status ok. The result from
  // where the motion the bones had while ok leads is kept unless the other leaves fewer bones in
  // doubt or fits clearly better, every bone's outline counted.
  RegistrationResult from_before;
  try {
    from_before =
        continuing_registrar_->solve(views, restart_after_doubt_, loaded, priors, recentSpreads());
  } catch (const InputError&) {
    return;  // e.g. a bone those poses put outside a view: the continued result stands
  }
  const QualitySettings quality = everySampleCounted(registrar_->settings().quality);
  const int before_trouble = statusTrouble(classifyBones(from_before, quality));
  const int continued_trouble = statusTrouble(frame->status);
  if (continued_trouble < before_trouble ||
      fitsClearlyBetter(frame->result, continued_trouble, from_before, before_trouble,
                        std::vector<bool>(frame->result.quality.size(), true))) {
    return;
  }
  frame->result = std::move(from_before);
  frame->status = classifyBones(frame->result, quality);
}

TrackedFrame Tracker::track(const std::vector<ViewImage>& views, const std::vector<bool>& loaded) {
  if (poses_.empty()) return searchAndReset(views);
  if (recovering_) {
    for (const ViewImage& view : views) {
      if (view.image.empty()) throw InputError("tracker: empty image");
    }
    // Neither the registration nor the search below can find anything in a frame that shows
    // nothing, and on noise both would take their time.
    const std::string nothing =
        featurelessViews(views, registrar_->settings().featureless_noise_ratio);
    if (!nothing.empty()) return giveUp(nothing);
    double tried_seconds = 0.0;
    if (!search_requested_ && registrar_->settings().tracking_recovery_registration) {
      std::optional<TrackedFrame> registered =
          registeredFromLastGoodPoses(views, loaded, &tried_seconds);
      if (registered) return std::move(*registered);
    }
    try {
      TrackedFrame found = searchAndReset(views);
      found.solve_seconds += tried_seconds;
      return found;
    } catch (const InputError& e) {
      // Nothing found in this frame: still lost, at the last good poses; search the next.
      TrackedFrame frame = giveUp(e.what());
      frame.searched = true;
      frame.solve_seconds = tried_seconds;
      return frame;
    }
  }
  std::vector<geometry::Pose> guess = poses_;
  if (previous_.size() == poses_.size()) {
    guess = predictPoses(previous_, poses_, registrar_->joints(),
                         registrar_->settings().tracking_prediction);
  }
  last_guess_ = guess;
  const auto start = std::chrono::steady_clock::now();
  TrackedFrame frame;
  // A frame started from an earlier frame's registration continues its side of a mirror
  // ambiguity (see MirrorCheckSettings), which that registration (or the search) chose: the
  // motion so far is better evidence than the neutral-joint rule. Poses given by the user (the
  // first frame, reinitialize) are checked.
  const EdgeOffsetPriors priors = edge_offsets_.priors(registrar_->bones().size(), views.size());
  frame.result = poses_registered_
                     ? continuing_registrar_->solve(views, guess, loaded, priors, recentSpreads())
                     : registrar_->solve(views, guess, loaded, priors);
  const QualitySettings quality = everySampleCounted(registrar_->settings().quality);
  frame.status = classifyBones(frame.result, quality);
  if (!restart_after_doubt_.empty() && poses_registered_ && continuing_registrar_ != registrar_ &&
      registrar_->settings().tracking_restart_after_suspect) {
    preferThePosesBeforeDoubt(views, loaded, priors, &frame);
  }
  restart_after_doubt_.clear();
  if (statusTrouble(frame.status) > 0) {
    // Before the retries and the search, which a frame that shows nothing only keeps busy.
    const std::string nothing =
        featurelessViews(views, registrar_->settings().featureless_noise_ratio);
    if (!nothing.empty()) {
      TrackedFrame given_up = giveUp(nothing);
      given_up.solve_seconds = secondsSince(start);
      return given_up;
    }
  }
  const bool more_doubt = statusTrouble(frame.status) > previous_trouble_;
  const std::vector<bool> fits_worse = fitsWorseThanRecently(frame.result, views.size());
  const bool any_fits_worse =
      std::find(fits_worse.begin(), fits_worse.end(), true) != fits_worse.end();
  if (poses_registered_ && continuing_registrar_ != registrar_ &&
      registrar_->settings().tracking_retry && (more_doubt || any_fits_worse)) {
    // The continued registration left the frame in more doubt than the last one, or a bone fits
    // clearly worse than in its recent frames (see RegistrationSettings::tracking_retry): the
    // full schedule, from the prediction and, when it extrapolated, from the last good poses.
    // (Doubt that persists, e.g. contour under an occluder, is the image's, which no start
    // changes.)
    std::vector<std::vector<geometry::Pose>> starts = {guess};
    if (previous_.size() == poses_.size()) starts.push_back(poses_);
    const RegistrationResult continued = frame.result;
    const std::vector<std::string> continued_status = frame.status;
    const auto continued_rank = resultRank(continued, quality);
    auto best_rank = continued_rank;
    // As the registrar's depth retry: with threads to spare both starts are solved at once, the
    // second left unused when the first clears the doubt (and one that throws re-solved below,
    // so that it throws only where one thread would).
    std::vector<std::optional<RegistrationResult>> retries(starts.size());
    if (registrar_->settings().threads > 1) {
      parallelFor(starts.size(), registrar_->settings().threads, [&](std::size_t k) {
        try {
          retries[k] = retrying_registrar_->solve(views, starts[k], loaded, priors);
        } catch (const std::exception&) {
        }
      });
    }
    for (std::size_t k = 0; k < starts.size(); ++k) {
      if (!retries[k]) retries[k] = retrying_registrar_->solve(views, starts[k], loaded, priors);
      RegistrationResult& retry = *retries[k];
      const auto rank = resultRank(retry, quality);
      const bool qualifies = more_doubt ? fitsAboutAsMuch(retry, continued, continued_status)
                                        : fitsClearlyBetter(retry, rank.first, continued,
                                                            continued_rank.first, fits_worse);
      if (rank < best_rank && qualifies) {
        best_rank = rank;
        frame.result = std::move(retry);
      }
      // Without doubt to clear, both starts are weighed.
      if (more_doubt && best_rank.first == 0) break;
    }
    frame.status = classifyBones(frame.result, quality);
  }
  const double shift_search_m = 1e-3 * registrar_->settings().tracking_shift_search_mm;
  if (shift_search_m > 0.0 && statusTrouble(frame.status) > 0) {
    // The start may have missed a knee that travelled across the views, or the poses the user
    // gave may be off by more than a registration captures (see
    // RegistrationSettings::tracking_shift_search_mm).
    const auto shifted = posesShiftedToEdges(registrar_->bones(), guess, views,
                                             registrar_->settings().edges, shift_search_m);
    if (shifted) {
      RegistrationResult retry = registrar_->solve(views, *shifted, loaded, priors);
      if (resultRank(retry, quality) < resultRank(frame.result, quality)) {
        frame.result = std::move(retry);
        frame.status = classifyBones(frame.result, quality);
      }
    }
  }
  frame.solve_seconds = secondsSince(start);
  frame.poses = frame.result.poses;
  const bool any_lost =
      std::find(frame.status.begin(), frame.status.end(), "lost") != frame.status.end();
  if (any_lost && search_) {
    // Search this very frame (seeded by the last good poses) rather than give it up: e.g. a
    // crude first-frame guess, or a jump the prediction missed. Blank or unusable frames find
    // nothing and stay lost; the next frames are then searched.
    try {
      TrackedFrame searched = searchAndReset(views);
      searched.solve_seconds += frame.solve_seconds;
      return searched;
    } catch (const InputError&) {
    }
  }
  accept(&frame);
  return frame;
}

}  // namespace registration
}  // namespace fluoro_tracker
