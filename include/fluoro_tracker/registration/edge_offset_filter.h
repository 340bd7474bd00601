#pragma once

#include <cstddef>
#include <vector>

#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace registration {

// Carries each bone's edge offset (RegistrationSettings::EdgeOffsetModel) from frame to frame
// while tracking: a scalar Kalman filter per bone and view. The offset is a property of the
// implant's rim and the imaging chain, so it changes slowly; one frame alone estimates it
// poorly, because a uniform offset and a small move along the beam change the silhouette
// almost alike. Pooled over frames it steadies the out-of-plane position.
class EdgeOffsetFilter {
 public:
  // `initial_sigma_px`: the prior before any frame (RegistrationSettings::edge_offset_prior_px).
  EdgeOffsetFilter(EdgeOffsetTrackingSettings settings, double initial_sigma_px);

  // Priors for the next frame of `bones` bones in `views` views: the last estimates, widened by
  // one frame's drift. Empty (the registrar's own zero-mean prior) when the filter is off or
  // has seen no frame with this many views.
  EdgeOffsetPriors priors(std::size_t bones, std::size_t views) const;

  // Takes a frame's estimates (per bone and view, as in RegistrationResult::edge_offsets_px),
  // registered with priors(): the estimate is the new mean, and the variance shrinks as one
  // frame's measurement would shrink it. Bones with `usable` false (lost) keep their belief,
  // widened by the frame's drift.
  void update(const std::vector<std::vector<double>>& offsets_px, const std::vector<bool>& usable);

 private:
  EdgeOffsetTrackingSettings settings_;
  double initial_sigma_px_;
  EdgeOffsetPriors beliefs_;  // per bone and view, after the last update
};

}  // namespace registration
}  // namespace fluoro_tracker
