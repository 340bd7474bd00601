#include "fluoro_tracker/io/trial_models.h"

#include <memory>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/kinematics/joint_types.h"

namespace fluoro_tracker {
namespace io {

TrialModels loadTrialModels(const TrialConfig& config) {
  TrialModels models;
  std::vector<geometry::Mesh> articular;  // per bone: the surface used for contact
  for (const auto& bone : config.bones) {
    geometry::MeshLoadOptions load;
    load.file_units = bone.mesh_units;
    const geometry::Mesh mesh = geometry::Mesh::load(bone.mesh, load);
    models.bones.push_back(
        {bone.name, std::make_shared<imaging::SilhouetteModel>(mesh), bone.image_weight});
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
    registration::JointModel model;
    try {
      model.type = kinematics::jointTypeFromName(joint.type);
    } catch (const InputError& e) {
      throw InputError("joint '" + joint.name + "': " + e.what());
    }
    model.name = joint.name;
    model.parent = index(joint.parent);
    model.child = index(joint.child);
    if (model.parent < 0 || model.child < 0) {
      throw InputError("joint '" + joint.name + "' names a bone that is not in the trial");
    }
    model.side = joint.side;
    model.parent_anatomical = config.bones[model.parent].anatomical_frame;
    model.child_anatomical = config.bones[model.child].anatomical_frame;
    model.ligaments = joint.ligaments;
    if (joint.contact.enabled) {
      try {
        model.contact = std::make_shared<constraints::ArticularContact>(
            articular[model.parent], articular[model.child], joint.contact);
        model.loaded_contact = std::make_shared<constraints::ArticularContact>(
            articular[model.parent], articular[model.child],
            constraints::stayInContactSettings(joint.contact, joint.contact.loaded_weight));
      } catch (const InputError& e) {
        throw InputError("joint '" + joint.name + "': " + e.what());
      }
    }
    models.joints.push_back(std::move(model));
  }
  return models;
}

}  // namespace io
}  // namespace fluoro_tracker
