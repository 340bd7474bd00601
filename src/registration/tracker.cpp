#include "fluoro_tracker/registration/tracker.h"

#include <chrono>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace registration {

Tracker::Tracker(std::shared_ptr<const Registrar> registrar, std::vector<geometry::Pose> initial)
    : registrar_(std::move(registrar)), poses_(std::move(initial)) {
  if (!registrar_) throw InputError("tracker: no registrar");
  if (poses_.size() != registrar_->bones().size()) {
    throw InputError("tracker: " + std::to_string(poses_.size()) + " initial pose(s) for " +
                     std::to_string(registrar_->bones().size()) + " bone(s)");
  }
  for (std::size_t b = 0; b < poses_.size(); ++b) {
    if (!geometry::isValidPose(poses_[b])) {
      throw InputError("tracker: the initial pose of bone '" + registrar_->bones()[b].name +
                       "' is not a finite rigid transform");
    }
  }
}

void Tracker::reinitialize(const std::vector<std::string>& bones,
                           const std::vector<geometry::Pose>& poses) {
  if (bones.size() != poses.size()) {
    throw InputError("reinitialize: " + std::to_string(bones.size()) + " bone name(s) but " +
                     std::to_string(poses.size()) + " pose(s)");
  }
  std::vector<geometry::Pose> updated = poses_;
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
}

TrackedFrame Tracker::track(const std::vector<ViewImage>& views, const std::vector<bool>& loaded) {
  std::vector<geometry::Pose> guess = poses_;
  if (previous_.size() == poses_.size()) {
    // Constant velocity: repeat the last frame-to-frame motion.
    for (std::size_t b = 0; b < guess.size(); ++b) {
      guess[b] = geometry::normalized(poses_[b] * (previous_[b].inverse() * poses_[b]));
    }
  }
  const auto start = std::chrono::steady_clock::now();
  TrackedFrame frame;
  frame.result = registrar_->solve(views, guess, loaded);
  frame.solve_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  frame.poses = frame.result.poses;
  frame.status.assign(poses_.size(), "ok");
  bool all_good = true;
  for (std::size_t b = 0; b < poses_.size(); ++b) {
    if (frame.result.diverged[b] || !geometry::isValidPose(frame.poses[b])) {
      frame.status[b] = "lost";
      frame.poses[b] = poses_[b];
      all_good = false;
    }
  }
  previous_ = all_good ? poses_ : std::vector<geometry::Pose>();
  poses_ = frame.poses;
  return frame;
}

}  // namespace registration
}  // namespace fluoro_tracker
