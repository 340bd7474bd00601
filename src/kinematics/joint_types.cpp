#include "fluoro_tracker/kinematics/joint_types.h"

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace kinematics {
namespace {

struct Convention {
  JointType type;
  const char* name;
  JointCoordinateNames names;
  double first_angle_sign;  // relative to the knee's flexion (the others keep the knee's signs)
};

const std::array<Convention, 4>& conventions() {
  static const std::array<Convention, 4> table = {{
      {JointType::kKnee,
       "knee",
       {{"flexion", "adduction", "internal_rotation"}, {"anterior", "superior", "lateral"}},
       1.0},
      // Dorsiflexion and elbow flexion turn the distal segment the other way about e1 from
      // knee flexion (its front up, or its distal end anterior).
      {JointType::kAnkle,
       "ankle",
       {{"dorsiflexion", "inversion", "internal_rotation"}, {"anterior", "superior", "lateral"}},
       -1.0},
      {JointType::kSubtalar,
       "subtalar",
       {{"dorsiflexion", "inversion", "internal_rotation"}, {"anterior", "superior", "lateral"}},
       -1.0},
      {JointType::kElbow,
       "elbow",
       {{"flexion", "varus", "pronation"}, {"anterior", "superior", "lateral"}},
       -1.0},
  }};
  return table;
}

const Convention& conventionOf(JointType type) {
  for (const Convention& c : conventions()) {
    if (c.type == type) return c;
  }
  return conventions().front();
}

}  // namespace

JointType jointTypeFromName(const std::string& name) {
  std::string accepted;
  for (const Convention& c : conventions()) {
    if (name == c.name) return c.type;
    accepted += (accepted.empty() ? "" : ", ") + std::string(c.name);
  }
  throw InputError("joint type '" + name + "' is not one of " + accepted +
                   " (glenohumeral, radioulnar and patellofemoral systems are not available)");
}

std::string jointTypeName(JointType type) {
  return conventionOf(type).name;
}

const JointCoordinateNames& coordinateNames(JointType type) {
  return conventionOf(type).names;
}

KneeCoordinates inJointConvention(JointType type, const KneeCoordinates& knee) {
  KneeCoordinates out = knee;
  out.flexion_rad *= conventionOf(type).first_angle_sign;
  return out;
}

}  // namespace kinematics
}  // namespace fluoro_tracker
