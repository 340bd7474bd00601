#include "fluoro_tracker/registration/edge_offset_filter.h"

#include <cmath>

namespace fluoro_tracker {
namespace registration {

EdgeOffsetFilter::EdgeOffsetFilter(EdgeOffsetTrackingSettings settings, double initial_sigma_px)
    : settings_(settings), initial_sigma_px_(initial_sigma_px) {}

EdgeOffsetPriors EdgeOffsetFilter::priors(std::size_t bones, std::size_t views) const {
  if (!settings_.enabled || initial_sigma_px_ <= 0.0 || beliefs_.size() != bones ||
      beliefs_.empty() || beliefs_.front().size() != views) {
    return {};
  }
  EdgeOffsetPriors next = beliefs_;
  for (auto& per_view : next) {
    for (EdgeOffsetPrior& prior : per_view) {
      prior.sigma_px = std::hypot(prior.sigma_px, settings_.drift_px);
    }
  }
  return next;
}

void EdgeOffsetFilter::update(const std::vector<std::vector<double>>& offsets_px,
                              const std::vector<bool>& usable) {
  if (!settings_.enabled || initial_sigma_px_ <= 0.0 || offsets_px.empty()) return;
  const std::size_t views = offsets_px.front().size();
  // What the frame was registered with: the carried beliefs, or the registrar's own prior.
  EdgeOffsetPriors prior = priors(offsets_px.size(), views);
  if (prior.empty()) {
    EdgeOffsetPrior fresh;
    fresh.sigma_px = initial_sigma_px_;
    prior.assign(offsets_px.size(), std::vector<EdgeOffsetPrior>(views, fresh));
  }
  const double measurement_variance = settings_.frame_sd_px * settings_.frame_sd_px;
  for (std::size_t b = 0; b < offsets_px.size() && b < usable.size(); ++b) {
    if (!usable[b] || offsets_px[b].size() != views) continue;  // the prior, widened, stays
    for (std::size_t v = 0; v < views; ++v) {
      if (!std::isfinite(offsets_px[b][v])) continue;
      const double variance = prior[b][v].sigma_px * prior[b][v].sigma_px;
      prior[b][v].mean_px = offsets_px[b][v];
      prior[b][v].sigma_px = std::sqrt(1.0 / (1.0 / variance + 1.0 / measurement_variance));
    }
  }
  beliefs_ = std::move(prior);
}

}  // namespace registration
}  // namespace fluoro_tracker
