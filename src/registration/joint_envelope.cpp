#include "fluoro_tracker/registration/joint_envelope.h"

#include <algorithm>
#include <cmath>

#include "fluoro_tracker/kinematics/joint_types.h"

namespace fluoro_tracker {
namespace registration {

namespace {

bool isShoulder(const JointModel& joint) {
  return joint.type == kinematics::JointType::kGlenohumeral;
}

// The middle of a coordinate's bounds, 0 when a bound is open.
double middle(const constraints::CoordinateBounds& b) {
  return std::isfinite(b.lower) && std::isfinite(b.upper) ? 0.5 * (b.lower + b.upper) : 0.0;
}

}  // namespace

kinematics::KneeCoordinates envelopeCoordinates(const JointModel& joint,
                                                const geometry::Pose& parent_pose,
                                                const geometry::Pose& child_pose) {
  return isShoulder(joint) ? joint.reportedCoordinates(parent_pose, child_pose)
                           : joint.coordinates(parent_pose, child_pose);
}

geometry::Pose jointPartner(const JointModel& joint, const geometry::Pose& known,
                            const kinematics::KneeCoordinates& k, bool child_missing) {
  // The child's frame in the parent's: anatomical frames for a shoulder, else knee frames.
  const geometry::Pose relative =
      isShoulder(joint)
          ? kinematics::distalFromJointCoordinates(joint.type, geometry::Pose::Identity(), k,
                                                   joint.side)
          : kinematics::tibiaFromKneeCoordinates(geometry::Pose::Identity(), k, joint.side);
  const geometry::Pose parent_frame =
      isShoulder(joint) ? joint.parent_anatomical : joint.parentKneeFrame();
  const geometry::Pose child_frame =
      isShoulder(joint) ? joint.child_anatomical : joint.childKneeFrame();
  if (child_missing) return known * parent_frame * relative * child_frame.inverse();
  return known * child_frame * relative.inverse() * parent_frame.inverse();
}

kinematics::KneeCoordinates clampedToEnvelope(const constraints::LigamentSettings& ligaments,
                                              kinematics::KneeCoordinates k) {
  const auto& b = ligaments.bounds;
  const auto clamp = [](double value, const constraints::CoordinateBounds& bounds, double unit) {
    return std::clamp(value, bounds.lower * unit, bounds.upper * unit);
  };
  const double rad_per_deg = geometry::degToRad(1.0);
  k.flexion_rad = clamp(k.flexion_rad, b[0], rad_per_deg);
  k.adduction_rad = clamp(k.adduction_rad, b[1], rad_per_deg);
  k.internal_rotation_rad = clamp(k.internal_rotation_rad, b[2], rad_per_deg);
  k.x_m = clamp(k.x_m, b[3], 1e-3);
  k.y_m = clamp(k.y_m, b[4], 1e-3);
  k.z_m = clamp(k.z_m, b[5], 1e-3);
  return k;
}

std::vector<geometry::Pose> envelopeSamples(const JointModel& joint, double flexion_step_deg,
                                            bool one_anterior, double anterior_step_mm) {
  const auto& bounds = joint.ligaments.bounds;
  const geometry::Pose parent = geometry::Pose::Identity();
  if (isShoulder(joint)) {
    const double lowest = std::isfinite(bounds[1].lower) ? bounds[1].lower : -150.0;
    const double highest = std::isfinite(bounds[1].upper) ? bounds[1].upper : 0.0;
    std::vector<geometry::Pose> samples;
    for (double elevation = highest; elevation >= lowest - 1e-9; elevation -= flexion_step_deg) {
      kinematics::KneeCoordinates k;
      k.flexion_rad = geometry::degToRad(middle(bounds[0]));  // plane of elevation
      k.adduction_rad = geometry::degToRad(elevation);
      k.internal_rotation_rad = geometry::degToRad(middle(bounds[2]));  // axial rotation
      k.x_m = middle(bounds[3]) * 1e-3;
      k.y_m = middle(bounds[4]) * 1e-3;
      k.z_m = middle(bounds[5]) * 1e-3;
      samples.push_back(jointPartner(joint, parent, k, true));
    }
    return samples;
  }
  const double lowest = std::isfinite(bounds[0].lower) ? bounds[0].lower : -10.0;
  const double highest = std::isfinite(bounds[0].upper) ? bounds[0].upper : 150.0;
  const bool free_distraction = !std::isfinite(bounds[4].lower) || !std::isfinite(bounds[4].upper);
  std::vector<double> anterior_mm = {middle(bounds[3])};
  if (!one_anterior && std::isfinite(bounds[3].lower) && std::isfinite(bounds[3].upper)) {
    anterior_mm.clear();
    for (double x = bounds[3].lower; x <= bounds[3].upper + 1e-9; x += anterior_step_mm) {
      anterior_mm.push_back(x);
    }
  }
  std::vector<geometry::Pose> samples;
  for (double flexion = lowest; flexion <= highest + 1e-9; flexion += flexion_step_deg) {
    for (double x_mm : anterior_mm) {
      kinematics::KneeCoordinates k;
      k.flexion_rad = geometry::degToRad(flexion);
      k.adduction_rad = geometry::degToRad(middle(bounds[1]));
      k.internal_rotation_rad = geometry::degToRad(middle(bounds[2]));
      k.x_m = x_mm * 1e-3;
      k.y_m = middle(bounds[4]) * 1e-3;
      k.z_m = middle(bounds[5]) * 1e-3;
      geometry::Pose child = jointPartner(joint, parent, k, true);
      if (free_distraction && joint.contact) {
        // Move the child along e3 (y: the tibia's long axis) by the signed gap until the surfaces
        // touch. A tibia lies below the femur, so a gap closes upward (+y); a patella lies in
        // front of it and its e3 is its anterior axis, so there a gap closes backward (-y).
        const double closing = joint.type == kinematics::JointType::kPatellofemoral ? -1.0 : 1.0;
        for (int iteration = 0; iteration < 8; ++iteration) {
          const double gap = joint.contact->figures(parent, child, false).min_distance_m;
          if (!std::isfinite(gap) || std::abs(gap) < 2e-4) break;
          k.y_m += closing * std::clamp(gap, -0.03, 0.03);
          child = jointPartner(joint, parent, k, true);
        }
      }
      samples.push_back(child);
    }
  }
  return samples;
}

}  // namespace registration
}  // namespace fluoro_tracker
