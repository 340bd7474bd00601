#include "fluoro_tracker/registration/inlier_history.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace fluoro_tracker {
namespace registration {

InlierHistory::InlierHistory(const QualitySettings& settings)
    : drop_(settings.relative_inlier_drop),
      spread_(settings.relative_inlier_spread),
      window_(static_cast<std::size_t>(std::max(settings.relative_inlier_window, 1))),
      min_frames_(static_cast<std::size_t>(std::max(settings.relative_inlier_min_frames, 1))) {}

namespace {

double medianOf(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t half = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + half, values.end());
  if (values.size() % 2 == 1) return values[half];
  const double upper = values[half];
  const double lower = *std::max_element(values.begin(), values.begin() + half);
  return 0.5 * (lower + upper);
}

}  // namespace

double InlierHistory::median(std::size_t bone) const {
  if (bone >= recent_.size()) return std::numeric_limits<double>::quiet_NaN();
  return medianOf(std::vector<double>(recent_[bone].begin(), recent_[bone].end()));
}

double InlierHistory::allowedDrop(std::size_t bone) const {
  const double centre = median(bone);
  if (!std::isfinite(centre)) return drop_;
  std::vector<double> deviations;
  for (const double f : recent_[bone]) deviations.push_back(std::abs(f - centre));
  // 1.4826 x the median absolute deviation: the standard deviation of a normal scatter.
  return std::max(drop_, spread_ * 1.4826 * medianOf(std::move(deviations)));
}

void InlierHistory::classify(const std::vector<BoneQuality>& quality,
                             std::vector<std::string>* status) {
  const std::size_t bones = std::min(quality.size(), status->size());
  if (recent_.size() < bones) recent_.resize(bones);
  for (std::size_t b = 0; b < bones; ++b) {
    const double fraction = quality[b].contour_inlier_fraction;
    std::string& bone_status = (*status)[b];
    if (drop_ > 0.0 && bone_status == "ok" && recent_[b].size() >= min_frames_ &&
        fraction < median(b) - allowedDrop(b)) {
      bone_status = "suspect";
    }
    if (bone_status == "lost") continue;
    recent_[b].push_back(fraction);
    if (recent_[b].size() > window_) recent_[b].pop_front();
  }
}

}  // namespace registration
}  // namespace fluoro_tracker
