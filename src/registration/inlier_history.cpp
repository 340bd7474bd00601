#include "fluoro_tracker/registration/inlier_history.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "fluoro_tracker/median.h"

namespace fluoro_tracker {
namespace registration {

InlierHistory::InlierHistory(const QualitySettings& settings)
    : quality_(settings),
      drop_(settings.relative_inlier_drop),
      spread_(settings.relative_inlier_spread),
      window_(static_cast<std::size_t>(std::max(settings.relative_inlier_window, 1))),
      min_frames_(static_cast<std::size_t>(std::max(settings.relative_inlier_min_frames, 1))),
      trend_frames_(static_cast<std::size_t>(std::max(settings.relative_inlier_trend_frames, 0))) {}

double InlierHistory::median(std::size_t bone) const {
  if (bone >= recent_.size() || recent_[bone].empty()) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return fluoro_tracker::median(std::vector<double>(recent_[bone].begin(), recent_[bone].end()));
}

double InlierHistory::fractionOf(const BoneQuality& quality) const {
  return statusInlierFraction(quality, quality_);
}

bool InlierHistory::fallsBelowMedian(std::size_t bone, double fraction, double drop) const {
  if (bone >= recent_.size() || recent_[bone].size() < min_frames_) return false;
  return fraction < median(bone) - drop;
}

double InlierHistory::reference(std::size_t bone) const {
  return referenceAround(bone, median(bone));
}

double InlierHistory::referenceAround(std::size_t bone, double centre) const {
  if (trend_frames_ == 0 || bone >= recent_.size() || recent_[bone].size() < trend_frames_) {
    return centre;
  }
  const std::vector<double> last(recent_[bone].end() - static_cast<std::ptrdiff_t>(trend_frames_),
                                 recent_[bone].end());
  // Theil-Sen: the median of the pairwise slopes, then the median intercept; a frame or two
  // off the line hardly moves either.
  std::vector<double> slopes;
  for (std::size_t i = 0; i < last.size(); ++i) {
    for (std::size_t j = i + 1; j < last.size(); ++j) {
      slopes.push_back((last[j] - last[i]) / static_cast<double>(j - i));
    }
  }
  const double slope = fluoro_tracker::median(std::move(slopes));
  std::vector<double> intercepts;
  for (std::size_t i = 0; i < last.size(); ++i) {
    intercepts.push_back(last[i] - slope * static_cast<double>(i));
  }
  const double next =
      fluoro_tracker::median(std::move(intercepts)) + slope * static_cast<double>(last.size());
  // Rising fractions promise nothing: never more than the best of those frames.
  return std::min(next, *std::max_element(last.begin(), last.end()));
}

double InlierHistory::allowedDrop(std::size_t bone) const {
  return allowedDropAround(bone, median(bone));
}

double InlierHistory::allowedDropAround(std::size_t bone, double centre) const {
  if (!std::isfinite(centre)) return drop_;
  std::vector<double> deviations;
  for (const double f : recent_[bone]) deviations.push_back(std::abs(f - centre));
  // 1.4826 x the median absolute deviation: the standard deviation of a normal scatter.
  return std::max(drop_, spread_ * 1.4826 * fluoro_tracker::median(std::move(deviations)));
}

void InlierHistory::classify(const std::vector<BoneQuality>& quality,
                             std::vector<std::string>* status) {
  const std::size_t bones = std::min(quality.size(), status->size());
  if (recent_.size() < bones) recent_.resize(bones);
  for (std::size_t b = 0; b < bones; ++b) {
    const double fraction = fractionOf(quality[b]);
    std::string& bone_status = (*status)[b];
    if (drop_ > 0.0 && bone_status == "ok" && recent_[b].size() >= min_frames_) {
      // The allowance comes from the scatter about the window's median; the reference may
      // follow a trend.
      const double centre = median(b);
      if (fraction < referenceAround(b, centre) - allowedDropAround(b, centre)) {
        bone_status = "suspect";
      }
    }
  }
  record(quality, *status);
}

void InlierHistory::record(const std::vector<BoneQuality>& quality,
                           const std::vector<std::string>& status) {
  const std::size_t bones = std::min(quality.size(), status.size());
  if (recent_.size() < bones) recent_.resize(bones);
  for (std::size_t b = 0; b < bones; ++b) {
    if (status[b] == "lost") continue;
    recent_[b].push_back(fractionOf(quality[b]));
    if (recent_[b].size() > window_) recent_[b].pop_front();
  }
}

}  // namespace registration
}  // namespace fluoro_tracker
