#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fluoro_tracker/constraints/articular_contact.h"
#include "fluoro_tracker/constraints/ligament_envelope.h"
#include "fluoro_tracker/geometry/length_unit.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/kinematics/knee_coordinates.h"
#include "fluoro_tracker/registration/pose_search.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace io {

struct BoneConfig {
  std::string name;
  std::string mesh;  // absolute path (relative paths in the YAML are resolved against its folder)
  geometry::LengthUnit mesh_units = geometry::LengthUnit::kMillimetre;
  // Surface that takes part in articular contact but not in the image term, e.g. the
  // polyethylene insert on a metal tibial tray. Empty: the image mesh is used for contact.
  std::string articular_mesh;
  // Pose of the bone frame in fixed_frame at the first frame (metres); none: find it
  // automatically.
  std::optional<geometry::Pose> initial_pose;
  // Weight of the bone's image terms (e.g. 2 for a femur whose image is the more reliable).
  double image_weight = 1.0;
  // The bone's anatomical frame (ISB: X anterior, Y superior, Z right) in its mesh frame, for
  // joint kinematics; identity when the mesh is already in anatomical axes.
  geometry::Pose anatomical_frame = geometry::Pose::Identity();
};

struct JointConfig {
  std::string name;
  std::string parent;
  std::string child;
  std::string type = "knee";  // a kinematics::JointType's name (jointTypeFromName)
  kinematics::Side side = kinematics::Side::kRight;
  // Articular contact between the parent's surface and the child's (articular_mesh, or the
  // image mesh when none is given). A joint without a `contact:` section has it disabled.
  constraints::ContactSettings contact;
  // Ligament-like springs on the joint coordinates. A joint without a `ligaments:` section has
  // them disabled.
  constraints::LigamentSettings ligaments;
};

// The trial YAML of docs/interfaces.md. Later layers add their own typed sections.
struct TrialConfig {
  std::string fixed_frame;  // empty: the first view's optical frame
  std::vector<BoneConfig> bones;
  std::vector<JointConfig> joints;
  registration::RegistrationSettings registration;  // the optional `registration:` section
  registration::PoseSearchSettings search;          // its `search:` subsection

  const BoneConfig* findBone(const std::string& name) const;
  // Every bone's initial pose in bone order, or none when some bone has none (the tracker then
  // finds them all with the automatic search).
  std::vector<geometry::Pose> initialPoses() const;
};

// Throws InputError naming the file, the key and (for YAML syntax errors) the line.
TrialConfig loadTrialConfig(const std::string& path);
// Writes mesh paths relative to the YAML file's folder when they lie below it.
void saveTrialConfig(const std::string& path, const TrialConfig& config);

}  // namespace io
}  // namespace fluoro_tracker
