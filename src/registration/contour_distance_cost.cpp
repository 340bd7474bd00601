#include "fluoro_tracker/registration/contour_distance_cost.h"

#include <algorithm>
#include <cmath>

#include "fluoro_tracker/registration/pose_increment.h"

namespace fluoro_tracker {
namespace registration {

ContourDistanceCost::ContourDistanceCost(const imaging::EdgeMap* edge_map,
                                         std::vector<Eigen::Vector3d> points_fixed,
                                         std::vector<Eigen::Vector2d> offset_directions,
                                         const Eigen::Vector3d& centre, double robust_scale_px,
                                         double weight, std::vector<Eigen::Vector2d> fixed_shifts)
    : edge_map_(edge_map),
      points_(std::move(points_fixed)),
      normals_(std::move(offset_directions)),
      shifts_(std::move(fixed_shifts)),
      centre_(centre),
      camera_from_fixed_(edge_map->camera().worldFromCamera().inverse()),
      robust_(robust_scale_px),
      sqrt_weight_(std::sqrt(weight)),
      sampled_at_({6, 1}) {
  set_num_residuals(static_cast<int>(points_.size()));
  samples_.resize(points_.size());
  mutable_parameter_block_sizes()->push_back(6);
  mutable_parameter_block_sizes()->push_back(1);
}

bool ContourDistanceCost::Evaluate(double const* const* parameters, double* residuals,
                                   double** jacobians) const {
  const IncrementedPoints moved(parameters[0], centre_, camera_from_fixed_);
  const geometry::XrayCamera& camera = edge_map_->camera();
  double* jac = (jacobians != nullptr) ? jacobians[0] : nullptr;
  double* jac_offset = (jacobians != nullptr) ? jacobians[1] : nullptr;
  const double offset = parameters[1][0];
  // Ceres evaluates the cost alone at a candidate step and, when it accepts the step, again
  // with Jacobians at the same parameters: the edge map's samples are then those of the last
  // evaluation.
  const bool resample = sampled_at_.moved(parameters);
  if (!resample && jacobians == nullptr) {
    for (std::size_t i = 0; i < points_.size(); ++i) residuals[i] = samples_[i].residual;
    return true;
  }
  for (std::size_t i = 0; i < points_.size(); ++i) {
    Eigen::Vector3d rotated;
    const Eigen::Vector3d pc = moved.toCamera(points_[i], &rotated);
    Sample& sample = samples_[i];
    if (resample) {
      double distance = 0.0;
      sample.du = 0.0;
      sample.dv = 0.0;
      sample.valid = pc.z() > 0.0;
      if (sample.valid) {
        const double inv_z = 1.0 / pc.z();
        double u = camera.fx() * pc.x() * inv_z + camera.cx() + offset * normals_[i].x();
        double v = camera.fy() * pc.y() * inv_z + camera.cy() + offset * normals_[i].y();
        if (!shifts_.empty()) {
          u += shifts_[i].x();
          v += shifts_[i].y();
        }
        sample.valid = edge_map_->sample(u, v, &distance, &sample.du, &sample.dv);
      }
      sample.residual = sqrt_weight_ * robust_(distance, &sample.slope);
    }
    residuals[i] = sample.residual;
    const double slope = sample.slope;
    const double du = sample.du;
    const double dv = sample.dv;
    if (jac_offset != nullptr) {
      jac_offset[i] =
          sample.valid ? sqrt_weight_ * slope * (du * normals_[i].x() + dv * normals_[i].y()) : 0.0;
    }
    if (jac == nullptr) continue;
    double* row = jac + 6 * i;
    if (!sample.valid) {
      std::fill(row, row + 6, 0.0);
      continue;
    }
    // d(distance)/d(camera point) = gradient · d(pixel)/d(point).
    const double inv_z = 1.0 / pc.z();
    const Eigen::RowVector3d d_pc =
        sqrt_weight_ * slope *
        Eigen::RowVector3d(
            du * camera.fx() * inv_z, dv * camera.fy() * inv_z,
            -(du * camera.fx() * pc.x() + dv * camera.fy() * pc.y()) * inv_z * inv_z);
    moved.chain(d_pc, rotated, row);
  }
  return true;
}

}  // namespace registration
}  // namespace fluoro_tracker
