#pragma once

#include <array>
#include <string>

#include "fluoro_tracker/kinematics/knee_coordinates.h"

namespace fluoro_tracker {
namespace kinematics {

// Joints whose coordinate system is of the Grood & Suntay kind: e1 is the proximal segment's Z
// (medial-lateral) axis, e3 the distal segment's Y (long) axis, and e2 the floating axis e3 x e1.
// Both segments' anatomical frames follow the ISB orientation (X anterior, Y proximal, Z to the
// right), so the geometry is kneeCoordinates'; only the clinical names and signs differ. For the
// right side (the left mirrors it, as for the knee):
//   knee (tibiofemoral; Grood & Suntay 1983): flexion (+: the tibia's distal end moves
//     posterior), adduction (+: varus), internal rotation (+: the tibia's front turns medially).
//   ankle (tibiotalar: tibia -> talus; Wu et al. 2002) and subtalar (talocalcaneal: talus ->
//     calcaneus; Wu et al. 2002): dorsiflexion (+: the distal segment's front moves up),
//     inversion (+: the sole turns medially), internal rotation (+: the front turns medially).
//   elbow (humeroulnar: humerus -> ulna; Wu et al. 2005), radiohumeral (humerus -> radius) and
//     radioulnar (ulna -> radius, e1 the ulna's Z and e3 the radius' Y, the elbow's system
//     applied to the forearm's two bones): flexion (+: the distal segment's distal end moves
//     anterior), varus (+: its distal end moves medially), pronation (+: it turns internally
//     about its long axis).
// Translations, for every type above: the distal frame's origin relative to the proximal
// frame's, along e2 (anterior), e3 (superior, i.e. proximal) and e1 (lateral).
//
// patellofemoral (femur -> patella; the joint coordinate system of Bull et al. 2002): e1 the
// femur's Z, e3 the patella's X (anterior, normal to its anterior surface), e2 = e3 x e1
// floating (distal when the patella lies in the femur's orientation). Flexion about e1 (+: the
// patella's distal pole moves posterior, as the tibia's in knee flexion), lateral tilt about e2
// (+: the anterior surface turns to face laterally, its lateral edge moving posterior), medial
// rotation about e3 (+: the distal pole moves medially); translations of the patella origin
// along e2 (distal), e3 (anterior) and e1 (lateral: patellar shift). Computed as the knee's
// coordinates of both frames turned -90 deg about their Z (their Y then the patella's X).
//
// glenohumeral (scapula -> humerus; Wu et al. 2005, ISB shoulder): an Euler sequence Y-X-Y
// instead, the humerus' rotation in the scapula frame being Ry(plane_of_elevation)
// Rx(elevation) Ry(axial_rotation) for the right side: plane of elevation 0 for abduction and
// 90 deg for forward flexion; elevation with the ISB's sign, negative as the arm rises (taken in
// [-180, 0] deg); axial rotation positive internal (the front turns medially). With the arm
// along the trunk (elevation 0) the first and third axes coincide: the whole turn is then
// reported as axial rotation and the plane of elevation as 0. Translations: the humerus
// origin relative to the scapula origin along the scapula's X (anterior), Y (superior) and Z
// (lateral). The left side mirrors the right, as for the other types.
enum class JointType {
  kKnee,
  kAnkle,
  kSubtalar,
  kElbow,
  kRadiohumeral,
  kRadioulnar,
  kPatellofemoral,
  kGlenohumeral
};

// "knee", "ankle", "subtalar", "elbow", "radiohumeral", "radioulnar", "patellofemoral",
// "glenohumeral"; throws InputError naming the accepted types.
JointType jointTypeFromName(const std::string& name);
std::string jointTypeName(JointType type);

struct JointCoordinateNames {
  std::array<std::string, 3> angles;        // about e1, e2, e3
  std::array<std::string, 3> translations;  // along e2, e3, e1
};
const JointCoordinateNames& coordinateNames(JointType type);

// Whether the type's coordinates are the knee's of the same two frames but for the first
// angle's sign (the Grood & Suntay kinds with e3 the distal Y axis). Not patellofemoral or
// glenohumeral.
bool hasKneeCoordinates(JointType type);

// Whether the type's coordinates are the knee's of its two anatomical frames each turned by
// kneeFrameTurn, but for the first angle's sign (firstAngleSign): every type but glenohumeral,
// whose coordinates are an Euler sequence. The registration's own terms (ligament springs, the
// pose search's envelope) act on the knee coordinates of the turned frames, so a joint's
// ligament bounds are its type's own coordinates.
bool hasKneeFrameCoordinates(JointType type);

// The turn of both anatomical frames (composed on their right) under which the type's
// coordinates are the knee's (see hasKneeFrameCoordinates): the identity for the types with
// hasKneeCoordinates, -90 deg about Z for patellofemoral (e3 then the patella's X). Throws
// InputError for glenohumeral.
const geometry::Pose& kneeFrameTurn(JointType type);

// The joint's clinical coordinates from the knee-convention ones of the same two frames (in the
// same fields and order: angle about e1, e2, e3; translation along e2, e3, e1). For the types
// with hasKneeCoordinates only; throws InputError for the others.
KneeCoordinates inJointConvention(JointType type, const KneeCoordinates& knee);

// For the types with hasKneeFrameCoordinates: their first angle is this times the knee's
// flexion of the turned frames (+1 or -1); their other coordinates are the knee's. Throws
// InputError for glenohumeral.
double firstAngleSign(JointType type);

// Any type's coordinates (the three angles, then the three translations, in the fields of
// KneeCoordinates in that order) from the two anatomical frames' poses (any common frame).
KneeCoordinates jointCoordinates(JointType type, const geometry::Pose& proximal,
                                 const geometry::Pose& distal, Side side);
// The distal segment's anatomical frame for given coordinates of any type: the inverse of
// jointCoordinates (for glenohumeral, up to the plane of elevation where elevation is 0 or
// -180 deg).
geometry::Pose distalFromJointCoordinates(JointType type, const geometry::Pose& proximal,
                                          const KneeCoordinates& coordinates, Side side);

}  // namespace kinematics
}  // namespace fluoro_tracker
