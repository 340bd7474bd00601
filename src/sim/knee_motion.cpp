#include "fluoro_tracker/sim/knee_motion.h"

#include <cmath>
#include <limits>

#include <fcl/narrowphase/collision.h>

#include "fluoro_tracker/geometry/mesh_bvh.h"
#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace sim {

void KneeMotionSettings::validate() const {
  if (frames < 1) throw InputError("knee motion: frames must be >= 1");
  if (!(frame_rate_hz > 0.0)) throw InputError("knee motion: frame_rate_hz must be > 0");
  if (!(max_flexion_deg >= start_flexion_deg)) {
    throw InputError("knee motion: max_flexion_deg must be >= start_flexion_deg");
  }
  if (max_flexion_deg > 150.0 || start_flexion_deg < -10.0) {
    throw InputError("knee motion: flexion must stay within -10..150 deg");
  }
  if (!joint_travel_mm.allFinite()) throw InputError("knee motion: joint_travel_mm must be finite");
}

Eigen::Vector3d jointTravelAt(const KneeMotionSettings& settings, int index) {
  const double progress =
      settings.frames > 1 ? static_cast<double>(index) / (settings.frames - 1) - 0.5 : 0.0;
  return 1e-3 * progress * settings.joint_travel_mm;
}

double femurInsertClearance(const geometry::Pose& tibia_from_femur, const KneeImplantSet& implants,
                            const KneeImplantDimensions& dimensions) {
  double clearance = std::numeric_limits<double>::infinity();
  for (const auto& v : implants.femoral_component.vertices()) {
    const Eigen::Vector3d p = tibia_from_femur * v;
    if (!isOverInsert(dimensions, p.x(), p.z())) continue;
    clearance = std::min(clearance, p.y() - insertSurfaceHeight(dimensions, p.x(), p.z()));
  }
  return clearance;
}

struct KneeContactSolver::Bvhs {
  std::shared_ptr<geometry::MeshBvh> femur;
  std::shared_ptr<geometry::MeshBvh> insert;
};

KneeContactSolver::KneeContactSolver(const KneeImplantSet& implants,
                                     const KneeImplantDimensions& dimensions)
    : bvhs_(std::make_shared<Bvhs>(Bvhs{geometry::buildBvh(implants.femoral_component),
                                        geometry::buildBvh(implants.tibial_insert)})),
      implants_(&implants),
      dimensions_(dimensions) {}

bool KneeContactSolver::collides(const geometry::Pose& tibia_from_femur) const {
  const fcl::CollisionObjectd femur(bvhs_->femur, tibia_from_femur.linear(),
                                    tibia_from_femur.translation());
  const fcl::CollisionObjectd insert(bvhs_->insert);
  fcl::CollisionRequestd request;
  fcl::CollisionResultd result;
  fcl::collide(&femur, &insert, request, result);
  return result.isCollision();
}

geometry::Pose KneeContactSolver::settle(const geometry::Pose& tibia_from_femur) const {
  // Start from the vertex-based estimate over the generated insert's surface (from the pose as
  // given for an insert read from a file), then bracket [penetrating, clear] and bisect.
  geometry::Pose pose = tibia_from_femur;
  if (implants_->insert_generated) {
    const double clearance = femurInsertClearance(pose, *implants_, dimensions_);
    if (!std::isfinite(clearance)) {
      throw InputError("knee contact: the femoral component is not above the insert");
    }
    pose.translation().y() -= clearance;
  }
  const auto at = [&](double lift) {
    geometry::Pose p = pose;
    p.translation().y() += lift;
    return p;
  };
  double low = 0.0;
  double high = 0.0;
  constexpr double kStep = 2e-4;
  if (collides(at(0.0))) {
    while (collides(at(high))) {
      low = high;
      high += kStep;
      if (high > 0.05) throw InputError("knee contact: cannot separate femur and insert");
    }
  } else {
    while (!collides(at(low))) {
      high = low;
      low -= kStep;
      if (low < -0.05) throw InputError("knee contact: femur never reaches the insert");
    }
  }
  while (high - low > 1e-6) {
    const double mid = 0.5 * (low + high);
    (collides(at(mid)) ? low : high) = mid;
  }
  return at(high);
}

KneeFramePose kneePoseAt(const KneeMotionSettings& s, int index, const KneeContactSolver& contact) {
  // Phase 0 -> 1 -> 0 over the trial (half a cosine each way: smooth at the ends).
  const double progress = s.frames > 1 ? static_cast<double>(index) / (s.frames - 1) : 0.0;
  const double phase = 0.5 * (1.0 - std::cos(2.0 * M_PI * progress));
  KneeFramePose out;
  out.flexion_deg = s.start_flexion_deg + (s.max_flexion_deg - s.start_flexion_deg) * phase;
  const double internal_rotation = s.internal_rotation_at_max_deg * phase;
  const double rollback_mm = s.rollback_at_max_mm * phase;
  const double adduction = s.adduction_amplitude_deg * std::sin(4.0 * M_PI * progress);
  out.shank_inclination_deg = s.shank_inclination_ratio * out.flexion_deg;

  // Femur orientation in the tibia frame, the inverse of the Grood & Suntay sequence of
  // kinematics::KneeCoordinates (tibia in femur = Rz(-flexion) Rx(adduction) Ry(internal)): in
  // flexion the femoral shaft tilts posteriorly over the tibia (+Z), so the posterior condyles
  // come down onto the insert.
  const Eigen::Matrix3d rotation = geometry::rotationY(-geometry::degToRad(internal_rotation)) *
                                   geometry::rotationX(-geometry::degToRad(adduction)) *
                                   geometry::rotationZ(geometry::degToRad(out.flexion_deg));
  const geometry::Pose pose =
      geometry::makePose(rotation, Eigen::Vector3d(-1e-3 * rollback_mm, 0.0, 0.0));
  out.tibia_from_femur = contact.settle(pose);
  return out;
}

}  // namespace sim
}  // namespace fluoro_tracker
