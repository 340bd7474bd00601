#pragma once

#include <cstddef>
#include <deque>
#include <string>
#include <vector>

#include "fluoro_tracker/registration/frame_quality.h"

namespace fluoro_tracker {
namespace registration {

// A bone's contour inlier fraction at its true pose depends on the trial: near 1 on a clean
// image, 0.8-0.95 under an occluding rod, noise or a low resolution (contour covered by another
// bone is not counted, see BoneQuality). The absolute thresholds of QualitySettings must pass the
// poorest of those, so a wrong pose on a clean image (a femur found on the wrong rim, about 0.6-0.8
// of its contour on edges) is called ok. InlierHistory compares each bone with itself: it keeps
// the inlier fractions of the bone's recent frames and marks a bone suspect whose fraction lies
// more than QualitySettings::relative_inlier_drop below their median (or, when they scatter
// more, relative_inlier_spread robust standard deviations below it: under a moving rod a
// bone's good frames differ by more than the drop). Once the bone has
// relative_inlier_trend_frames frames, the reference is instead the robust line through its
// last few fractions, carried on to the new frame: a bone's fraction at its true pose also
// drifts with the pose (the tray's outline fades where thigh and calf overlap in deep
// flexion), and against the median such a drift was flagged frame after frame. Every frame
// that is not lost joins the history, so a lasting change (an occluder that stays) becomes the
// new normal within a few frames, while a single frame hardly moves the reference.
// Used by the Tracker (frames in order) and by the benchmark (each trial's frames in order).
class InlierHistory {
 public:
  explicit InlierHistory(const QualitySettings& settings);

  // Turns "ok" bones whose inlier fraction dropped below their history "suspect" (with
  // min_frames of history; relative_inlier_drop 0 turns the test off), then records the
  // fractions of the bones not lost. `quality` and `status` are per bone.
  void classify(const std::vector<BoneQuality>& quality, std::vector<std::string>* status);

  // Only records the fractions of the bones not lost, as classify does after its test.
  void record(const std::vector<BoneQuality>& quality, const std::vector<std::string>& status);

  // The fraction of a bone's figures that the history records and compares: the one the
  // status tests use (statusInlierFraction).
  double fractionOf(const BoneQuality& quality) const;

  // The median of a bone's recorded fractions (the upper middle one of an even count; NaN
  // without any).
  double median(std::size_t bone) const;

  // Whether a bone's fraction lies more than `drop` below the median of its recorded fractions,
  // once it has min_frames of them (false before).
  bool fallsBelowMedian(std::size_t bone, double fraction, double drop) const;

  // How far below the median a bone's fraction may lie before it is suspect.
  double allowedDrop(std::size_t bone) const;

  // What a bone's next fraction is compared with: the trend line's value for the next frame
  // (capped at the highest of the frames it runs through) once there are trend_frames_ of
  // them, the median before (NaN without any).
  double reference(std::size_t bone) const;

 private:
  double allowedDropAround(std::size_t bone, double centre) const;
  // reference() given the bone's median `centre`.
  double referenceAround(std::size_t bone, double centre) const;

  QualitySettings quality_;
  double drop_;
  double spread_;
  std::size_t window_;
  std::size_t min_frames_;
  std::size_t trend_frames_;                // 0: median only
  std::vector<std::deque<double>> recent_;  // per bone, oldest first
};

}  // namespace registration
}  // namespace fluoro_tracker
