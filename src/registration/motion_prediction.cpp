#include "fluoro_tracker/registration/motion_prediction.h"

#include "fluoro_tracker/kinematics/joint_types.h"
#include "fluoro_tracker/kinematics/knee_coordinates.h"

namespace fluoro_tracker {
namespace registration {

std::vector<geometry::Pose> predictPoses(const std::vector<geometry::Pose>& previous,
                                         const std::vector<geometry::Pose>& current,
                                         const std::vector<JointModel>& joints,
                                         RegistrationSettings::TrackingPrediction prediction) {
  std::vector<geometry::Pose> predicted = current;
  for (std::size_t b = 0; b < current.size(); ++b) {
    predicted[b] = geometry::normalized(current[b] * (previous[b].inverse() * current[b]));
  }
  if (prediction != RegistrationSettings::TrackingPrediction::kJointCoordinates) return predicted;

  // Joints whose child is placed from its parent, parents first: a joint waits until no
  // pending joint has its parent as child (one pass per level of a chain).
  std::vector<const JointModel*> pending;
  for (const JointModel& joint : joints) {
    const bool usable = joint.parent >= 0 && joint.child >= 0 &&
                        static_cast<std::size_t>(joint.parent) < current.size() &&
                        static_cast<std::size_t>(joint.child) < current.size() &&
                        kinematics::hasKneeFrameCoordinates(joint.type);
    if (usable) pending.push_back(&joint);
  }
  while (!pending.empty()) {
    std::vector<const JointModel*> waiting;
    for (const JointModel* joint : pending) {
      bool parent_pending = false;
      for (const JointModel* other : pending) {
        parent_pending = parent_pending || (other != joint && other->child == joint->parent);
      }
      if (parent_pending) {
        waiting.push_back(joint);
        continue;
      }
      const auto p = static_cast<std::size_t>(joint->parent);
      const auto c = static_cast<std::size_t>(joint->child);
      const kinematics::KneeCoordinates before = joint->coordinates(previous[p], previous[c]);
      const kinematics::KneeCoordinates now = joint->coordinates(current[p], current[c]);
      kinematics::KneeCoordinates next = now;
      next.flexion_rad += now.flexion_rad - before.flexion_rad;
      next.x_m += now.x_m - before.x_m;
      next.y_m += now.y_m - before.y_m;
      next.z_m += now.z_m - before.z_m;
      const geometry::Pose child_knee_frame = kinematics::tibiaFromKneeCoordinates(
          predicted[p] * joint->parentKneeFrame(), next, joint->side);
      const geometry::Pose child =
          geometry::normalized(child_knee_frame * joint->childKneeFrame().inverse());
      // Degenerate coordinates (the tibia's long axis along the flexion axis) leave the child
      // at constant velocity.
      if (child.matrix().allFinite()) predicted[c] = child;
    }
    if (waiting.size() == pending.size()) break;  // a cycle: the rest stay at constant velocity
    pending = std::move(waiting);
  }
  return predicted;
}

}  // namespace registration
}  // namespace fluoro_tracker
