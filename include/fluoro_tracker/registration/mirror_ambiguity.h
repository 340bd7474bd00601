#pragma once

#include "fluoro_tracker/constraints/ligament_envelope.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/kinematics/knee_coordinates.h"

namespace fluoro_tracker {
namespace registration {

// A single view cannot tell an implant that is symmetric about its sagittal plane (a tibial
// tray) from its mirror image through the plane that contains the beam: in orthographic
// projection the two have the same silhouette, and perspective separates them by a fraction
// of a pixel. A start on the wrong side converges to the mirror, off by twice the tilt and turn
// the true pose has relative to the beam.

// The pose of a bone mirrored through the plane across the beam (optical z) at its origin:
// the pose the view cannot tell from `camera_from_mesh`, for a mesh symmetric about its X-Y
// plane (the ISB frame's sagittal plane).
geometry::Pose mirroredAcrossBeam(const geometry::Pose& camera_from_mesh);

// The pose of a bone turned about its long axis (mesh Y) so that its medial-lateral axis (mesh
// Z) is mirrored through the plane that contains the long axis and the beam: its turn relative
// to the beam reversed, its tilt kept. For an implant nearly symmetric front to back (a tray
// seen from the side) the silhouette changes little. Returns the pose unchanged when the long
// axis lies along the beam.
geometry::Pose turnReflectedAcrossBeam(const geometry::Pose& camera_from_mesh);

// The pose of a bone with its tilt across the beam reversed and its turn about its long axis
// kept: the mirror (mirroredAcrossBeam) of its turn reflection. A tray seen nearly edge-on but
// turned some degrees about its stem has this pose's silhouette nearly as its own when only the
// plateau's tilt lies on the wrong side of edge-on; its full mirror is then off by twice the
// turn as well.
geometry::Pose tiltReflectedAcrossBeam(const geometry::Pose& camera_from_mesh);

// How far a joint is from neutral in the coordinates the mirror changes in a lateral view:
// |adduction| and |internal rotation - neutral rotation|, each in units of its ligament bound on
// that side (the envelope's half-width when a bound is open), where the neutral rotation is
// `neutral_rotation_per_flexion` degrees per degree of flexion (none in hyperextension). Of two
// poses that fit the image equally well, the registrar keeps the one nearer neutral: the knee's
// varus-valgus stays near 0 and its axial rotation near the rotation that comes with its
// flexion in most activities, while the mirror adds twice the view's obliquity to both.
double neutralDeviation(const constraints::LigamentSettings& ligaments,
                        const kinematics::KneeCoordinates& coordinates,
                        double neutral_rotation_per_flexion = 0.0);

}  // namespace registration
}  // namespace fluoro_tracker
