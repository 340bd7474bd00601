#pragma once

#include <memory>
#include <string>

#include "fluoro_tracker/registration/tracker.h"

namespace rosbag {
class Bag;
}

namespace fluoro_tracker {
namespace ros_bridge {

// An output bag of a tracked trial (track_bag --out-bag, ~play_bag output_bag_path): every
// message of the input bag, plus per frame the tf fixed_frame -> <bone> on /tf and the
// tracker's /fluoro_tracker/kinematics and /fluoro_tracker/status, at the image stamps, so that
// the result replays in step with the images (and any mocap or force topics in the input).
class ResultBag {
 public:
  // Throws InputError naming the path if it cannot be created.
  explicit ResultBag(const std::string& path);
  ~ResultBag();

  void addFrame(double stamp_s, const std::string& fixed_frame,
                const registration::Registrar& registrar,
                const registration::TrackedFrame& tracked);
  // Copies every message of `input_path`; throws InputError naming it if unreadable.
  void copyInput(const std::string& input_path);
  void close();

 private:
  std::string path_;
  std::unique_ptr<rosbag::Bag> bag_;
};

}  // namespace ros_bridge
}  // namespace fluoro_tracker
