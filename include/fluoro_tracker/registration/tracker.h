#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace registration {

// One tracked frame: each bone's pose and status, and the registration behind them.
struct TrackedFrame {
  std::vector<geometry::Pose> poses;  // in the fixed frame; never non-finite
  std::vector<std::string> status;    // per bone: "ok" or "lost"
  RegistrationResult result;
  double solve_seconds = 0.0;
};

// State across frames (architecture: registration::Tracker): each frame is registered from a
// constant-velocity prediction of the last two good frames; a bone whose solve diverges, or
// that comes back non-finite, keeps its last good pose, is reported lost, and the prediction
// restarts from its last good pose. ROS-free: used by track_bag and the tracking node.
class Tracker {
 public:
  // `initial`: per bone, its pose at the first frame (all are needed until automatic
  // initialisation exists). Throws InputError for a wrong count or a non-finite pose.
  Tracker(std::shared_ptr<const Registrar> registrar, std::vector<geometry::Pose> initial);

  const Registrar& registrar() const { return *registrar_; }
  const std::vector<geometry::Pose>& poses() const { return poses_; }

  // Sets some bones' poses (by name) and restarts the prediction. Throws InputError naming an
  // unknown bone or a non-finite pose; nothing changes then.
  void reinitialize(const std::vector<std::string>& bones,
                    const std::vector<geometry::Pose>& poses);

  // Registers one frame (all views). Throws InputError for unusable input (empty image,
  // mismatched sizes, a bone behind the source); the state is then unchanged.
  // `loaded`: per joint, whether it is known to be loaded in this frame (see Registrar::solve).
  TrackedFrame track(const std::vector<ViewImage>& views, const std::vector<bool>& loaded = {});

 private:
  std::shared_ptr<const Registrar> registrar_;
  std::vector<geometry::Pose> poses_;     // last good pose per bone
  std::vector<geometry::Pose> previous_;  // the good poses one frame earlier (empty: none)
};

}  // namespace registration
}  // namespace fluoro_tracker
