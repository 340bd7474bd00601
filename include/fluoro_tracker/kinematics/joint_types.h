#pragma once

#include <array>
#include <string>

#include "fluoro_tracker/kinematics/knee_coordinates.h"

namespace fluoro_tracker {
namespace kinematics {

// Joints whose ISB-recommended coordinate system is of the Grood & Suntay kind: e1 is the
// proximal segment's Z (medial-lateral) axis, e3 the distal segment's Y (long) axis, and e2 the
// floating axis e3 x e1. Both segments' anatomical frames follow the ISB orientation (X anterior,
// Y proximal, Z to the right), so the geometry is kneeCoordinates'; only the clinical names and
// signs differ. For the right side (the left mirrors it, as for the knee):
//   knee (tibiofemoral; Grood & Suntay 1983): flexion (+: the tibia's distal end moves
//     posterior), adduction (+: varus), internal rotation (+: the tibia's front turns medially).
//   ankle (tibiotalar: tibia -> talus; Wu et al. 2002) and subtalar (talocalcaneal: talus ->
//     calcaneus; Wu et al. 2002): dorsiflexion (+: the distal segment's front moves up),
//     inversion (+: the sole turns medially), internal rotation (+: the front turns medially).
//   elbow (humeroulnar: humerus -> ulna; Wu et al. 2005): flexion (+: the forearm's distal end
//     moves anterior), varus (+: the forearm's distal end moves medially), pronation (+: the
//     forearm turns internally about its long axis).
// Translations, for every type: the distal frame's origin relative to the proximal frame's,
// along e2 (anterior), e3 (superior, i.e. proximal) and e1 (lateral).
// Not covered (their ISB systems are Euler sequences of another kind): glenohumeral (Y-X-Y),
// radioulnar, patellofemoral.
enum class JointType { kKnee, kAnkle, kSubtalar, kElbow };

// "knee", "ankle", "subtalar", "elbow"; throws InputError naming the accepted types.
JointType jointTypeFromName(const std::string& name);
std::string jointTypeName(JointType type);

struct JointCoordinateNames {
  std::array<std::string, 3> angles;        // about e1, e2, e3
  std::array<std::string, 3> translations;  // along e2, e3, e1
};
const JointCoordinateNames& coordinateNames(JointType type);

// The joint's clinical coordinates from the knee-convention ones of the same two frames (in the
// same fields and order: angle about e1, e2, e3; translation along e2, e3, e1).
KneeCoordinates inJointConvention(JointType type, const KneeCoordinates& knee);

}  // namespace kinematics
}  // namespace fluoro_tracker
