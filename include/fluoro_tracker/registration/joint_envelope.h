#pragma once

#include <vector>

#include "fluoro_tracker/constraints/ligament_envelope.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/kinematics/knee_coordinates.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace registration {

// A joint's ligament envelope as poses, for the automatic search (PoseSearch): where one bone
// of a joint must lie given the other. In the coordinates its ligament bounds are on
// (envelopeCoordinates): the knee coordinates of the joint's knee frames (JointModel::
// coordinates), or a glenohumeral joint's own ISB angles.

// The coordinates of bones at these mesh-frame poses that the joint's bounds are on.
kinematics::KneeCoordinates envelopeCoordinates(const JointModel& joint,
                                                const geometry::Pose& parent_pose,
                                                const geometry::Pose& child_pose);

// The pose of the missing bone of a joint for given envelopeCoordinates and the other bone's
// pose (mesh frames; `child_missing`: the child is placed from the parent, else the parent from
// the child).
geometry::Pose jointPartner(const JointModel& joint, const geometry::Pose& known,
                            const kinematics::KneeCoordinates& coordinates, bool child_missing);

// Coordinates moved to the nearest point of the ligament envelope.
kinematics::KneeCoordinates clampedToEnvelope(const constraints::LigamentSettings& ligaments,
                                              kinematics::KneeCoordinates coordinates);

// The child's pose in the parent's mesh frame across the joint's envelope: flexion (the first
// knee coordinate) in `flexion_step_deg` steps over its bounds, anterior translation in
// `anterior_step_mm` steps over its bounds (or at its middle when `one_anterior`), every other
// coordinate at the middle of its bounds; an unbounded y translation (a knee's distraction) is
// set where the articular surfaces touch, when the joint has contact surfaces, since that is
// where a loaded joint is. A glenohumeral joint sweeps its elevation instead (over its bounds,
// else 0 to -150 deg: the arm rising), every other coordinate at the middle of its bounds (0 when
// unbounded: the humeral head on the glenoid for frames at the joint centre), without seating.
std::vector<geometry::Pose> envelopeSamples(const JointModel& joint, double flexion_step_deg,
                                            bool one_anterior, double anterior_step_mm = 10.0);

}  // namespace registration
}  // namespace fluoro_tracker
