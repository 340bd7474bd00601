#pragma once

#include <vector>

#include <ceres/cost_function.h>

#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/registration/cauchy_residual.h"
#include "fluoro_tracker/registration/evaluation_point.h"

namespace fluoro_tracker {
namespace registration {

// The reverse half of the dissertation's contour metric, for one bone in one view: image edge
// pixels near the projected contour, each paired (for one outer iteration) with its nearest
// contour sample, contribute their distance to that sample's tangent line, n·(e − u(δ)),
// Cauchy-robustified and weighted. It penalises a projection that is smaller than the edges
// around it, which the forward term alone would reward. Parameter blocks as the forward term's:
// the pose increment and the edge offset (which moves the tangent line outward). Analytic
// Jacobians. Not thread-safe: it keeps the last evaluation's residuals.
class EdgeToContourCost : public ceres::CostFunction {
 public:
  struct Pair {
    Eigen::Vector3d contour_point_fixed;  // contour sample at the current pose, fixed frame
    Eigen::Vector2d normal;               // its outward normal in the image
    Eigen::Vector2d edge_pixel;           // the image edge paired with it (sub-pixel)
    double offset_gain = 1.0;  // outward motion of the contour per unit of the edge offset
    double rounding = 0.0;     // the edge expected this far inside the sample (pixels)
  };

  EdgeToContourCost(const geometry::XrayCamera& camera, std::vector<Pair> pairs,
                    const Eigen::Vector3d& centre, double robust_scale_px, double weight);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  geometry::XrayCamera camera_;
  geometry::Pose camera_from_fixed_;
  std::vector<Pair> pairs_;
  Eigen::Vector3d centre_;
  CauchyResidual robust_;
  double sqrt_weight_;
  // The last evaluation's residuals and d(residual)/d(distance) per pair, and the parameters
  // (increment, offset) they were computed at.
  mutable std::vector<double> residuals_;
  mutable std::vector<double> slopes_;
  mutable EvaluationPoint evaluated_at_;
};

}  // namespace registration
}  // namespace fluoro_tracker
