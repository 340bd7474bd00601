#include "fluoro_tracker/kinematics/joint_types.h"

#include <cmath>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/kinematics/glenohumeral_angles.h"

namespace fluoro_tracker {
namespace kinematics {
namespace {

struct Convention {
  JointType type;
  const char* name;
  JointCoordinateNames names;
  // Relative to the knee's flexion (the others keep the knee's signs); 0: not the knee's
  // coordinates of any turn of the frames (hasKneeFrameCoordinates).
  double first_angle_sign;
  // The knee's coordinates of the frames turned by patellaTurn, not of the frames themselves.
  bool patella_turned = false;
};

const std::array<Convention, 8>& conventions() {
  // The translations of every Grood & Suntay kind, along e2, e3, e1.
  const std::array<std::string, 3> along = {"anterior", "superior", "lateral"};
  const JointCoordinateNames foot = {{"dorsiflexion", "inversion", "internal_rotation"}, along};
  const JointCoordinateNames forearm = {{"flexion", "varus", "pronation"}, along};
  static const std::array<Convention, 8> table = {{
      {JointType::kKnee, "knee", {{"flexion", "adduction", "internal_rotation"}, along}, 1.0},
      // Dorsiflexion and elbow flexion turn the distal segment the other way about e1 from
      // knee flexion (its front up, or its distal end anterior).
      {JointType::kAnkle, "ankle", foot, -1.0},
      {JointType::kSubtalar, "subtalar", foot, -1.0},
      {JointType::kElbow, "elbow", forearm, -1.0},
      {JointType::kRadiohumeral, "radiohumeral", forearm, -1.0},
      {JointType::kRadioulnar, "radioulnar", forearm, -1.0},
      // e3 is the patella's X: see patellaTurn.
      {JointType::kPatellofemoral,
       "patellofemoral",
       {{"flexion", "lateral_tilt", "medial_rotation"}, {"distal", "anterior", "lateral"}},
       1.0,
       true},
      // Not of the Grood & Suntay kind: see glenohumeralCoordinates.
      {JointType::kGlenohumeral,
       "glenohumeral",
       {{"plane_of_elevation", "elevation", "axial_rotation"}, along},
       0.0},
  }};
  return table;
}

const Convention& conventionOf(JointType type) {
  for (const Convention& c : conventions()) {
    if (c.type == type) return c;
  }
  return conventions().front();
}

// Turns a frame -90 deg about its Z: its Y becomes the former X. The patellofemoral coordinates
// are the knee's of the femur and patella turned so (e3 then the patella's anterior axis); the
// turn commutes with the left side's mirror through the X-Y plane.
const geometry::Pose& patellaTurn() {
  static const geometry::Pose turn =
      geometry::makePose(geometry::rotationZ(-M_PI / 2.0), Eigen::Vector3d::Zero());
  return turn;
}

// The mirror image through the sagittal plane (X-Y): a left joint as a right one, and back.
geometry::Pose mirroredThroughSagittalPlane(const geometry::Pose& relative) {
  const Eigen::Matrix3d mirror = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  return geometry::makePose(mirror * relative.linear() * mirror, mirror * relative.translation());
}

// The ISB's Y-X-Y angles (glenohumeralCoordinatesInScapulaFrame) of the humerus in the scapula.
KneeCoordinates glenohumeralCoordinates(const geometry::Pose& scapula,
                                        const geometry::Pose& humerus, Side side) {
  const geometry::Pose relative = scapula.inverse() * humerus;
  Eigen::Matrix3d r = relative.linear();
  Eigen::Vector3d t = relative.translation();
  glenohumeralAsRight(side, &r, &t);
  double c[6];
  glenohumeralCoordinatesInScapulaFrame(r, t, c);
  return {c[0], c[1], c[2], c[3], c[4], c[5]};
}

}  // namespace

JointType jointTypeFromName(const std::string& name) {
  std::string accepted;
  for (const Convention& c : conventions()) {
    if (name == c.name) return c.type;
    accepted += (accepted.empty() ? "" : ", ") + std::string(c.name);
  }
  throw InputError("joint type '" + name + "' is not one of " + accepted);
}

std::string jointTypeName(JointType type) {
  return conventionOf(type).name;
}

const JointCoordinateNames& coordinateNames(JointType type) {
  return conventionOf(type).names;
}

bool hasKneeFrameCoordinates(JointType type) {
  return conventionOf(type).first_angle_sign != 0.0;
}

bool hasKneeCoordinates(JointType type) {
  return hasKneeFrameCoordinates(type) && !conventionOf(type).patella_turned;
}

const geometry::Pose& kneeFrameTurn(JointType type) {
  static const geometry::Pose identity = geometry::Pose::Identity();
  if (!hasKneeFrameCoordinates(type)) {
    throw InputError(
        jointTypeName(type) +
        " coordinates are an Euler sequence, not the knee's of any turn of the frames");
  }
  return conventionOf(type).patella_turned ? patellaTurn() : identity;
}

double firstAngleSign(JointType type) {
  if (!hasKneeFrameCoordinates(type)) {
    throw InputError(jointTypeName(type) +
                     " coordinates come from the bones' poses, not the knee's");
  }
  return conventionOf(type).first_angle_sign;
}

KneeCoordinates inJointConvention(JointType type, const KneeCoordinates& knee) {
  if (!hasKneeCoordinates(type)) {
    throw InputError(jointTypeName(type) +
                     " coordinates come from the bones' poses, not the knee's of the same frames");
  }
  KneeCoordinates out = knee;
  out.flexion_rad *= firstAngleSign(type);
  return out;
}

KneeCoordinates jointCoordinates(JointType type, const geometry::Pose& proximal,
                                 const geometry::Pose& distal, Side side) {
  if (type == JointType::kGlenohumeral) return glenohumeralCoordinates(proximal, distal, side);
  if (type == JointType::kPatellofemoral) {
    return kneeCoordinates(proximal * patellaTurn(), distal * patellaTurn(), side);
  }
  return inJointConvention(type, kneeCoordinates(proximal, distal, side));
}

geometry::Pose distalFromJointCoordinates(JointType type, const geometry::Pose& proximal,
                                          const KneeCoordinates& c, Side side) {
  if (type == JointType::kGlenohumeral) {
    geometry::Pose relative = geometry::makePose(geometry::rotationY(c.flexion_rad) *
                                                     geometry::rotationX(c.adduction_rad) *
                                                     geometry::rotationY(c.internal_rotation_rad),
                                                 Eigen::Vector3d(c.x_m, c.y_m, c.z_m));
    if (side == Side::kLeft) relative = mirroredThroughSagittalPlane(relative);
    return proximal * relative;
  }
  if (type == JointType::kPatellofemoral) {
    return tibiaFromKneeCoordinates(proximal * patellaTurn(), c, side) * patellaTurn().inverse();
  }
  KneeCoordinates knee = c;
  knee.flexion_rad *= firstAngleSign(type);  // the sign is its own inverse
  return tibiaFromKneeCoordinates(proximal, knee, side);
}

}  // namespace kinematics
}  // namespace fluoro_tracker
