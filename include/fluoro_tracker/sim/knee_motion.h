#pragma once

#include <memory>

#include <Eigen/Core>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/sim/implant_models.h"

namespace fluoro_tracker {
namespace sim {

// A flexion cycle of a total knee: extension -> max flexion -> extension, with coupled tibial
// internal rotation, femoral rollback and a small varus-valgus wobble. At every frame the femur
// is lowered onto the insert until its condyles touch the articular surface (no penetration,
// no gap), so the simulated joint is in contact as a loaded knee is.
struct KneeMotionSettings {
  int frames = 60;
  double frame_rate_hz = 30.0;
  double start_flexion_deg = 5.0;
  double max_flexion_deg = 100.0;
  double internal_rotation_at_max_deg = 8.0;  // tibia internally rotates as the knee flexes
  double rollback_at_max_mm = 6.0;            // femur moves posterior on the tibia
  double adduction_amplitude_deg = 1.0;
  // The shank also inclines in the view as the knee flexes (a squat): fraction of flexion.
  double shank_inclination_ratio = 0.35;
  // The whole knee travels at constant velocity by this much (mm) over the trial, centred on
  // the joint's place in the view: x right and y down the first view's image, z along its beam
  // away from the source (a step-up or lunge that moves the knee across a fixed fluoroscope).
  Eigen::Vector3d joint_travel_mm = Eigen::Vector3d::Zero();

  void validate() const;
};

struct KneeFramePose {
  double flexion_deg = 0.0;
  geometry::Pose tibia_from_femur = geometry::Pose::Identity();  // metres
  double shank_inclination_deg = 0.0;
};

// Lowers the femoral component onto the insert along the tibial long axis until the two
// meshes touch: FCL collision tests between the actual meshes, bisected to 1 micrometre, so
// that no edge or rim penetrates (a vertex-only test misses the insert's rim in deep flexion).
class KneeContactSolver {
 public:
  KneeContactSolver(const KneeImplantSet& implants, const KneeImplantDimensions& dimensions);
  // The pose moved along tibial Y so that the meshes touch without penetrating.
  geometry::Pose settle(const geometry::Pose& tibia_from_femur) const;
  bool collides(const geometry::Pose& tibia_from_femur) const;

 private:
  struct Bvhs;
  std::shared_ptr<const Bvhs> bvhs_;
  const KneeImplantSet* implants_;
  KneeImplantDimensions dimensions_;
};

// Where the knee is at frame `index` relative to its place in the view (metres, the first view's
// camera frame): joint_travel_mm, from minus half of it at the first frame to plus half at the
// last.
Eigen::Vector3d jointTravelAt(const KneeMotionSettings& settings, int index);

// Pose of the femur on the tibia at frame `index`, resting on the insert.
KneeFramePose kneePoseAt(const KneeMotionSettings& settings, int index,
                         const KneeContactSolver& contact);

// Smallest height (m) of the femoral component's vertices above the insert's articular surface,
// over the vertices that lie above the insert: 0 when touching, < 0 when penetrating.
double femurInsertClearance(const geometry::Pose& tibia_from_femur, const KneeImplantSet& implants,
                            const KneeImplantDimensions& dimensions);

}  // namespace sim
}  // namespace fluoro_tracker
