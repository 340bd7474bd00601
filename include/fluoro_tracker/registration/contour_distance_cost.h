#pragma once

#include <vector>

#include <ceres/cost_function.h>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/imaging/edge_map.h"
#include "fluoro_tracker/registration/cauchy_residual.h"
#include "fluoro_tracker/registration/evaluation_point.h"

namespace fluoro_tracker {
namespace registration {

// The dissertation's contour metric as a Ceres residual block for one bone in one view: for each
// projected outer-contour point, the signed distance (pixels) from its projection to the nearest
// image edge, robustified per point with a Cauchy loss (so that contour points with no edge nearby,
// e.g. behind an occluder, stop pulling) and weighted. Two parameter blocks: the bone's pose
// increment (see pose_increment.h) and the bone's edge offset in this view (one value, see
// RegistrationSettings::edge_offset_model): each contour point is moved along its offset
// direction before it is compared, since the displayed edge of a real implant lies a fraction
// of a pixel inside its geometric silhouette (metal that thins toward a sharp rim, detector
// blur before a logarithmic display).
// Analytic Jacobians. Not thread-safe: it keeps the last evaluation's samples of the edge map.
class ContourDistanceCost : public ceres::CostFunction {
 public:
  // `points_fixed`: contour points at the current pose T0, in the fixed frame. `centre`: the
  // rotation centre of the increment. `edge_map` must outlive the cost.
  // `offset_directions`: how far (map pixels) and which way each point moves per unit of the
  // edge offset parameter. `fixed_shifts` (map pixels, per point; empty: none): a constant move
  // of each point's projection before it is compared, e.g. where the edge map's smoothing puts
  // a corner's edge (registration::cornerRounding).
  ContourDistanceCost(const imaging::EdgeMap* edge_map, std::vector<Eigen::Vector3d> points_fixed,
                      std::vector<Eigen::Vector2d> offset_directions, const Eigen::Vector3d& centre,
                      double robust_scale_px, double weight,
                      std::vector<Eigen::Vector2d> fixed_shifts = {});

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  // One contour point's look-up in the edge map and its robustified residual.
  struct Sample {
    double residual = 0.0;
    double slope = 0.0;  // d(residual)/d(distance), before the weight
    double du = 0.0;     // the distance's gradient in the map
    double dv = 0.0;
    bool valid = false;  // inside the map and in front of the source
  };

  const imaging::EdgeMap* edge_map_;
  std::vector<Eigen::Vector3d> points_;
  std::vector<Eigen::Vector2d> normals_;
  std::vector<Eigen::Vector2d> shifts_;  // per point, map pixels; empty: none
  Eigen::Vector3d centre_;
  geometry::Pose camera_from_fixed_;
  CauchyResidual robust_;
  double sqrt_weight_;
  // The last evaluation's samples and the parameters (increment, offset) they were taken at.
  mutable std::vector<Sample> samples_;
  mutable EvaluationPoint sampled_at_;
};

}  // namespace registration
}  // namespace fluoro_tracker
