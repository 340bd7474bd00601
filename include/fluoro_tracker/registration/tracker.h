#pragma once

#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/registration/edge_offset_filter.h"
#include "fluoro_tracker/registration/inlier_history.h"
#include "fluoro_tracker/registration/pose_search.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace registration {

// One tracked frame: each bone's pose and status, and the registration behind them.
struct TrackedFrame {
  std::vector<geometry::Pose> poses;  // in the fixed frame; never non-finite
  std::vector<std::string> status;    // per bone: "ok", "suspect" or "lost" (classifyBones)
  RegistrationResult result;
  double solve_seconds = 0.0;
  bool searched = false;  // the poses come from an automatic search (initialisation, recovery)
  // Per bone (empty unless searched): the search put the bone farther from where it last fitted
  // well than it can move in the frames since, so it is reported lost at its last good pose
  // instead (e.g. a frame showing the knee mirrored, or another knee).
  std::vector<bool> implausible_jump;
  // Why the frame was given up with every bone lost at its last good pose, when it was: it shows
  // nothing (RegistrationSettings::featureless_noise_ratio), or a recovery search found nothing.
  // Empty otherwise. For logs.
  std::string given_up;
};

// "the search found femur farther from the last good pose than ..." for a frame with
// TrackedFrame::implausible_jump set for some bone (named from `bones`); empty otherwise. For logs.
std::string describeImplausibleJumps(const TrackedFrame& frame,
                                     const std::vector<BoneModel>& bones);

// State across frames (architecture: registration::Tracker): each frame is registered from a
// prediction from the last two good frames (predictPoses, RegistrationSettings::
// tracking_prediction), and its quality classified
// (classifyBones, then InlierHistory against the bone's recent frames). A lost bone keeps its last
// good pose (the tracker never reports a jump its own quality rejects) and the prediction restarts
// from it. With a PoseSearch, the tracker also starts without poses (the first frame is searched)
// and recovers: a frame whose registration loses a bone is searched at once, seeded by the last
// good poses (so a crude first-frame guess costs no frame); if that finds nothing, each following
// frame is registered from the last good poses and, unless that leaves every bone ok, searched,
// until no bone is lost (RegistrationSettings::tracking_recovery_registration). A frame that
// shows nothing is given up without either (RegistrationSettings::featureless_noise_ratio). A
// recovery search whose bone lies farther from its pose in the last frame that called it ok than it
// can move in the frames since (RegistrationSettings::max_translation_from_start_m and
// max_rotation_from_start_rad per frame, the limits of one frame's registration) leaves that bone
// lost at its last good pose: a frame that shows a knee, but not this one where it was a moment
// ago, is not followed. The frame after the first one in doubt (a bone suspect, none lost) is
// also registered on from the frames before that one (RegistrationSettings::
// tracking_restart_after_suspect). Frames started from an earlier frame's registration skip the
// registrar's mirror check (the motion so far tells the side); frames started from poses the user
// gave (the first frame, reinitialize) have it as configured. ROS-free: used by track_bag and the
// tracking node.
class Tracker {
 public:
  // `initial`: per bone, its pose at the first frame. Empty: found by `search` on the first
  // frame (then required). Throws InputError for a wrong count, a non-finite pose, or no poses
  // and no search.
  Tracker(std::shared_ptr<const Registrar> registrar, std::vector<geometry::Pose> initial,
          std::shared_ptr<const PoseSearch> search = nullptr);

  const Registrar& registrar() const { return *registrar_; }
  // The last good poses; empty until the first frame when started without poses.
  const std::vector<geometry::Pose>& poses() const { return poses_; }
  bool initialized() const { return !poses_.empty(); }
  bool recovering() const { return recovering_; }
  bool canSearch() const { return search_ != nullptr; }

  void setSearch(std::shared_ptr<const PoseSearch> search) { search_ = std::move(search); }
  // The next frame is searched (seeded by the last good poses) instead of tracked. Throws
  // InputError without a search.
  void requestSearch();  // its result is taken wherever it lies (no implausible_jump test)

  // Searches the frame for every bone (seeded by the last good poses) and restarts tracking
  // there. Throws InputError when there is no search, or it finds no pose of some bone (the
  // state is then unchanged).
  TrackedFrame searchAndReset(const std::vector<ViewImage>& views);

  // Sets some bones' poses (by name) and restarts the prediction. Throws InputError naming an
  // unknown bone or a non-finite pose; nothing changes then.
  void reinitialize(const std::vector<std::string>& bones,
                    const std::vector<geometry::Pose>& poses);

  // Registers one frame (all views), searching it instead when not yet initialised or
  // recovering. Throws InputError for unusable input (empty image, mismatched sizes, a bone
  // behind the source) or a failed first search; the state is then unchanged.
  // `loaded`: per joint, whether it is known to be loaded in this frame (see Registrar::solve).
  TrackedFrame track(const std::vector<ViewImage>& views, const std::vector<bool>& loaded = {});

 private:
  // Takes a registered frame's poses by their status (lost bones keep their last good pose).
  void accept(TrackedFrame* frame);
  // A recovering frame registered from the last good poses (RegistrationSettings::
  // tracking_recovery_registration), taken (accept()) when every bone is ok; nothing otherwise,
  // and nothing changes. `seconds`: the time it took either way.
  std::optional<TrackedFrame> registeredFromLastGoodPoses(const std::vector<ViewImage>& views,
                                                          const std::vector<bool>& loaded,
                                                          double* seconds);
  // A frame after the first frame in doubt (RegistrationSettings::
  // tracking_restart_after_suspect): registers it from restart_after_doubt_ as well and takes
  // that result into `frame` unless its continued result leaves fewer bones in doubt or fits
  // clearly better (fitsClearlyBetter, every bone counted).
  void preferThePosesBeforeDoubt(const std::vector<ViewImage>& views,
                                 const std::vector<bool>& loaded, const EdgeOffsetPriors& priors,
                                 TrackedFrame* frame) const;
  // A frame given up for `reason` (TrackedFrame::given_up): every bone lost at its last good pose,
  // the state as it was but for the frames counted since each bone was last ok.
  TrackedFrame giveUp(const std::string& reason);
  // Marks lost (TrackedFrame::implausible_jump) each bone a recovery search put farther from its
  // pose in the last frame that called it ok than it can move in the frames since.
  void rejectImplausibleJumps(TrackedFrame* frame) const;
  // Whether every bone that shares a joint with bone `b` has status ok in `status`.
  bool jointPartnersOk(const std::vector<std::string>& status, std::size_t b) const;
  // Per bone: its inlier fraction lies more than RegistrationSettings::tracking_retry_inlier_drop
  // below the median of its recent frames (single view only; all false with more views).
  std::vector<bool> fitsWorseThanRecently(const RegistrationResult& result,
                                          std::size_t views) const;
  // Per bone, the median contour spread of its recent frames, which a continued frame's
  // rotation retry compares it with (RotationRetrySettings::tracking_spread_rise); NaN before
  // it has QualitySettings::relative_inlier_min_frames of them.
  std::vector<double> recentSpreads() const;
  // Whether a retry of a frame not in more doubt replaces its continued result: no more trouble
  // (statusTrouble, given for each), a lower final cost, and the bones in `fits_worse` gaining at
  // least tracking_retry_min_inlier_gain of inlier fraction together.
  bool fitsClearlyBetter(const RegistrationResult& retry, int retry_trouble,
                         const RegistrationResult& continued, int continued_trouble,
                         const std::vector<bool>& fits_worse) const;
  // Whether a retry of a frame in more doubt fits about as much of every bone's outline as the
  // continued result: no bone that is not lost there (`continued_status`) with its inlier
  // fraction lower by more than RegistrationSettings::tracking_retry_max_inlier_loss.
  bool fitsAboutAsMuch(const RegistrationResult& retry, const RegistrationResult& continued,
                       const std::vector<std::string>& continued_status) const;

  std::shared_ptr<const Registrar> registrar_;
  // The same registrar without the mirror check, for frames started from registered poses.
  std::shared_ptr<const Registrar> continuing_registrar_;
  // The full schedule for such a frame's retries: registrar_ with the tracking inner-edge
  // margin (RegistrationSettings::tracking_inner_edge_margin_px), as they start near too.
  std::shared_ptr<const Registrar> retrying_registrar_;
  std::shared_ptr<const PoseSearch> search_;
  // A bone was lost, or a search left one in doubt: search the next frames until all are ok.
  bool recovering_ = false;
  bool search_requested_ = false;  // requestSearch(): take the next search as found
  // Per bone: its pose in the last frame a registration called it and its joint partners ok,
  // and the frames since.
  std::vector<std::optional<geometry::Pose>> last_ok_;
  std::vector<int> frames_since_ok_;
  std::vector<geometry::Pose> poses_;     // last good pose per bone
  std::vector<geometry::Pose> previous_;  // the good poses one frame earlier (empty: none)
  bool poses_registered_ = false;         // poses_ come from a registration, not the user
  bool previous_all_ok_ = false;          // every bone ok in the last frame taken
  // When the last frame taken was the first to leave a bone in doubt (suspect, none lost) after
  // one with every bone ok: the poses predicted on from the frame before it, which the next
  // frame is registered from as well (RegistrationSettings::tracking_restart_after_suspect).
  // Empty otherwise.
  std::vector<geometry::Pose> restart_after_doubt_;
  std::vector<geometry::Pose> last_guess_;  // the start of the last frame tracked on
  int previous_trouble_ = 0;  // statusTrouble of the last frame taken (its classifyBones status)
  EdgeOffsetFilter edge_offsets_;  // each bone's edge offset, carried between frames
  // Each bone's recent inlier fractions, every contour sample counted (the tracker's decisions).
  InlierHistory inlier_history_;
  // The same as the status reported counts them (no unseen samples; see accept()).
  InlierHistory reported_history_;
  // The same of the fractions counted where the outline lies, for the retry of a bone that fits
  // worse than recently (fitsWorseThanRecently): a bone sliding along the beam with its edge
  // offset keeps its fraction at the offset, not this one.
  InlierHistory outline_history_;
  // Per bone, the contour spreads of its recent frames not lost (QualitySettings::
  // relative_inlier_window of them, oldest first), for recentSpreads().
  std::vector<std::deque<double>> recent_spreads_;
};

}  // namespace registration
}  // namespace fluoro_tracker
