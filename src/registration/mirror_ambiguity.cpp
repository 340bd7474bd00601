#include "fluoro_tracker/registration/mirror_ambiguity.h"

#include <algorithm>
#include <cmath>

namespace fluoro_tracker {
namespace registration {
namespace {

// |value| in units of the bound on its side; the half-width when that bound is open or on the
// wrong side of zero; degrees when both are open.
double inBoundUnits(double value_deg, const constraints::CoordinateBounds& bounds) {
  const double side = value_deg >= 0.0 ? bounds.upper : -bounds.lower;
  double unit = side;
  if (!(std::isfinite(unit) && unit > 0.0)) unit = 0.5 * (bounds.upper - bounds.lower);
  if (!(std::isfinite(unit) && unit > 0.0)) unit = 1.0;
  return std::abs(value_deg) / unit;
}

}  // namespace

geometry::Pose mirroredAcrossBeam(const geometry::Pose& camera_from_mesh) {
  const Eigen::Matrix3d flip = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  geometry::Pose mirrored = camera_from_mesh;
  mirrored.linear() = flip * camera_from_mesh.linear() * flip;
  return mirrored;
}

geometry::Pose turnReflectedAcrossBeam(const geometry::Pose& camera_from_mesh) {
  const Eigen::Vector3d axis = camera_from_mesh.linear().col(1);
  const Eigen::Vector3d beam = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d across = beam - beam.dot(axis) * axis;  // beam, perpendicular to axis
  if (across.norm() < 1e-6) return camera_from_mesh;
  const Eigen::Vector3d normal = axis.cross(across).normalized();  // of the plane (axis, beam)
  const Eigen::Vector3d lateral = camera_from_mesh.linear().col(2);
  const Eigen::Vector3d mirrored = lateral - 2.0 * lateral.dot(normal) * normal;
  const double angle = std::atan2(lateral.cross(mirrored).dot(axis), lateral.dot(mirrored));
  geometry::Pose turned = camera_from_mesh;
  turned.linear() = Eigen::AngleAxisd(angle, axis).toRotationMatrix() * camera_from_mesh.linear();
  return turned;
}

geometry::Pose tiltReflectedAcrossBeam(const geometry::Pose& camera_from_mesh) {
  return mirroredAcrossBeam(turnReflectedAcrossBeam(camera_from_mesh));
}

double neutralDeviation(const constraints::LigamentSettings& ligaments,
                        const kinematics::KneeCoordinates& coordinates,
                        double neutral_rotation_per_flexion) {
  const double neutral_rotation_deg =
      neutral_rotation_per_flexion * std::max(0.0, geometry::radToDeg(coordinates.flexion_rad));
  return inBoundUnits(geometry::radToDeg(coordinates.adduction_rad), ligaments.bounds[1]) +
         inBoundUnits(geometry::radToDeg(coordinates.internal_rotation_rad) - neutral_rotation_deg,
                      ligaments.bounds[2]);
}

}  // namespace registration
}  // namespace fluoro_tracker
