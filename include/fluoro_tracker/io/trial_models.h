#pragma once

#include <vector>

#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/io/trial_config.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace io {

// What a trial's registration needs from its files: each bone's image model and each joint's
// model (anatomical frames, contact model built once: signed distance grid and BVHs, ligament
// springs), in the order of the config.
struct TrialModels {
  std::vector<registration::BoneModel> bones;
  std::vector<registration::JointModel> joints;
};

// Loads every mesh the config names. Throws InputError naming the bone or joint and the file,
// or a joint type that kinematics::jointTypeFromName does not know.
TrialModels loadTrialModels(const TrialConfig& config);

}  // namespace io
}  // namespace fluoro_tracker
