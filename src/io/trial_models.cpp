#include "fluoro_tracker/io/trial_models.h"

#include <memory>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace io {

TrialModels loadTrialModels(const TrialConfig& config) {
  TrialModels models;
  std::vector<geometry::Mesh> articular;  // per bone: the surface used for contact
  for (const auto& bone : config.bones) {
    geometry::MeshLoadOptions load;
    load.file_units = bone.mesh_units;
    const geometry::Mesh mesh = geometry::Mesh::load(bone.mesh, load);
    models.bones.push_back({bone.name, std::make_shared<imaging::SilhouetteModel>(mesh), 1.0});
    articular.push_back(
        bone.articular_mesh.empty() ? mesh : geometry::Mesh::load(bone.articular_mesh, load));
  }
  auto index = [&config](const std::string& name) {
    for (std::size_t b = 0; b < config.bones.size(); ++b) {
      if (config.bones[b].name == name) return static_cast<int>(b);
    }
    return -1;
  };
  for (const auto& joint : config.joints) {
    if (!joint.contact.enabled) continue;
    const int parent = index(joint.parent);
    const int child = index(joint.child);
    if (parent < 0 || child < 0) {
      throw InputError("joint '" + joint.name + "' names a bone that is not in the trial");
    }
    try {
      models.contacts.push_back({joint.name, parent, child,
                                 std::make_shared<constraints::ArticularContact>(
                                     articular[parent], articular[child], joint.contact)});
    } catch (const InputError& e) {
      throw InputError("joint '" + joint.name + "': " + e.what());
    }
  }
  return models;
}

}  // namespace io
}  // namespace fluoro_tracker
