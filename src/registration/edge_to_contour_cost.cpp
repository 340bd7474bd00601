#include "fluoro_tracker/registration/edge_to_contour_cost.h"

#include <algorithm>
#include <cmath>

#include "fluoro_tracker/registration/contour_distance_cost.h"
#include "fluoro_tracker/registration/pose_increment.h"

namespace fluoro_tracker {
namespace registration {

EdgeToContourCost::EdgeToContourCost(const geometry::XrayCamera& camera, std::vector<Pair> pairs,
                                     const Eigen::Vector3d& centre, double robust_scale_px,
                                     double weight)
    : camera_(camera),
      camera_from_fixed_(camera.worldFromCamera().inverse()),
      pairs_(std::move(pairs)),
      centre_(centre),
      robust_(robust_scale_px),
      sqrt_weight_(std::sqrt(weight)),
      residuals_(pairs_.size(), 0.0),
      slopes_(pairs_.size(), 0.0),
      evaluated_at_({6, 1}) {
  set_num_residuals(static_cast<int>(pairs_.size()));
  mutable_parameter_block_sizes()->push_back(6);
  mutable_parameter_block_sizes()->push_back(1);
}

bool EdgeToContourCost::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  const IncrementedPoints moved(parameters[0], centre_, camera_from_fixed_);
  double* jac = (jacobians != nullptr) ? jacobians[0] : nullptr;
  double* jac_offset = (jacobians != nullptr) ? jacobians[1] : nullptr;
  const double offset = parameters[1][0];
  // Ceres evaluates the cost alone at a candidate step and, when it accepts the step, again
  // with Jacobians at the same parameters: the residuals and slopes are then the last ones.
  const bool recompute = evaluated_at_.moved(parameters);
  if (!recompute && jacobians == nullptr) {
    std::copy(residuals_.begin(), residuals_.end(), residuals);
    return true;
  }
  for (std::size_t i = 0; i < pairs_.size(); ++i) {
    const Pair& pair = pairs_[i];
    Eigen::Vector3d rotated;
    const Eigen::Vector3d pc = moved.toCamera(pair.contour_point_fixed, &rotated);
    if (!(pc.z() > 0.0)) {
      residuals_[i] = residuals[i] = 0.0;
      if (jac != nullptr) std::fill(jac + 6 * i, jac + 6 * i + 6, 0.0);
      if (jac_offset != nullptr) jac_offset[i] = 0.0;
      continue;
    }
    const double inv_z = 1.0 / pc.z();
    if (recompute) {
      const Eigen::Vector2d u(camera_.fx() * pc.x() * inv_z + camera_.cx(),
                              camera_.fy() * pc.y() * inv_z + camera_.cy());
      const double distance =
          pair.normal.dot(pair.edge_pixel - u) + pair.rounding - offset * pair.offset_gain;
      residuals_[i] = sqrt_weight_ * robust_(distance, &slopes_[i]);
    }
    residuals[i] = residuals_[i];
    const double slope = slopes_[i];
    if (jac_offset != nullptr) jac_offset[i] = -sqrt_weight_ * slope * pair.offset_gain;
    if (jac == nullptr) continue;
    // d(distance)/d(camera point) = -n · d(pixel)/d(point).
    const Eigen::RowVector3d d_pc =
        sqrt_weight_ * slope *
        Eigen::RowVector3d(
            -pair.normal.x() * camera_.fx() * inv_z, -pair.normal.y() * camera_.fy() * inv_z,
            (pair.normal.x() * camera_.fx() * pc.x() + pair.normal.y() * camera_.fy() * pc.y()) *
                inv_z * inv_z);
    moved.chain(d_pc, rotated, jac + 6 * i);
  }
  return true;
}

}  // namespace registration
}  // namespace fluoro_tracker
