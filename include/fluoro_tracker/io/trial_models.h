#pragma once

#include <vector>

#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/io/trial_config.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace io {

// What a trial's registration needs from its files: each bone's image model and each joint's
// contact model (built once: signed distance grids and BVHs), in the order of the config.
struct TrialModels {
  std::vector<registration::BoneModel> bones;
  std::vector<registration::ContactPair> contacts;  // joints with contact enabled
};

// Loads every mesh the config names. Throws InputError naming the bone or joint and the file.
TrialModels loadTrialModels(const TrialConfig& config);

}  // namespace io
}  // namespace fluoro_tracker
