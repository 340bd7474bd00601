#pragma once

#include <vector>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/registration/registrar.h"

namespace fluoro_tracker {
namespace registration {

// The tracker's start for the next frame from the last two good frames' poses (`previous`,
// then `current`; same bones, same order), as RegistrationSettings::tracking_prediction says:
// kConstantVelocity repeats each bone's last frame-to-frame motion; kJointCoordinates does so
// for every bone that is no joint's child, and places each joint's child from its parent's
// prediction by the joint's knee coordinates (JointModel::coordinates): flexion and the three
// translations at constant velocity, adduction and internal rotation held at `current`'s.
// A parent is predicted before its children. A joint without knee-frame coordinates
// (glenohumeral) leaves its child at constant velocity.
std::vector<geometry::Pose> predictPoses(const std::vector<geometry::Pose>& previous,
                                         const std::vector<geometry::Pose>& current,
                                         const std::vector<JointModel>& joints,
                                         RegistrationSettings::TrackingPrediction prediction);

}  // namespace registration
}  // namespace fluoro_tracker
