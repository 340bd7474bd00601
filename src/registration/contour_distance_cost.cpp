#include "fluoro_tracker/registration/contour_distance_cost.h"

#include <cmath>

#include "fluoro_tracker/registration/pose_increment.h"

namespace fluoro_tracker {
namespace registration {

ContourDistanceCost::ContourDistanceCost(const imaging::EdgeMap* edge_map,
                                         std::vector<Eigen::Vector3d> points_fixed,
                                         const Eigen::Vector3d& centre, double robust_scale_px,
                                         double weight)
    : edge_map_(edge_map),
      points_(std::move(points_fixed)),
      centre_(centre),
      camera_from_fixed_(edge_map->camera().worldFromCamera().inverse()),
      robust_scale_(robust_scale_px),
      sqrt_weight_(std::sqrt(weight)) {
  set_num_residuals(static_cast<int>(points_.size()));
  mutable_parameter_block_sizes()->push_back(6);
}

double ContourDistanceCost::robustResidual(double d, double b, double* derivative) {
  // Cauchy: rho(s) = b^2 log(1 + s / b^2), residual sqrt(rho(d^2)).
  const double ratio = d / b;
  if (std::abs(ratio) < 1e-6) {
    *derivative = 1.0;
    return d;
  }
  const double r = b * std::sqrt(std::log1p(ratio * ratio));
  *derivative = d / (r * (1.0 + ratio * ratio));
  return r;
}

bool ContourDistanceCost::Evaluate(double const* const* parameters, double* residuals,
                                   double** jacobians) const {
  const double* p = parameters[0];
  const Eigen::Vector3d w(p[0], p[1], p[2]);
  const Eigen::Vector3d t(p[3], p[4], p[5]);
  const double angle = w.norm();
  const Eigen::Matrix3d r = angle > 0.0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                                        : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d left_jacobian = so3LeftJacobian(w);
  const Eigen::Matrix3d rcf = camera_from_fixed_.linear();
  const Eigen::Vector3d tcf = camera_from_fixed_.translation();
  const geometry::XrayCamera& camera = edge_map_->camera();
  double* jac = (jacobians != nullptr) ? jacobians[0] : nullptr;

  for (std::size_t i = 0; i < points_.size(); ++i) {
    const Eigen::Vector3d v = r * (points_[i] - centre_);
    const Eigen::Vector3d pc = rcf * (v + centre_ + t) + tcf;
    double distance = 0.0;
    double du = 0.0;
    double dv = 0.0;
    bool valid = pc.z() > 0.0;
    if (valid) {
      const double inv_z = 1.0 / pc.z();
      const double u = camera.fx() * pc.x() * inv_z + camera.cx();
      const double vv = camera.fy() * pc.y() * inv_z + camera.cy();
      valid = edge_map_->sample(u, vv, &distance, &du, &dv);
    }
    double slope = 0.0;
    residuals[i] = sqrt_weight_ * robustResidual(distance, robust_scale_, &slope);
    if (jac == nullptr) continue;
    double* row = jac + 6 * i;
    if (!valid) {
      for (int k = 0; k < 6; ++k) row[k] = 0.0;
      continue;
    }
    const double inv_z = 1.0 / pc.z();
    // d(distance)/d(camera point) = grad · d(pixel)/d(point).
    const Eigen::RowVector3d d_pc(
        du * camera.fx() * inv_z, dv * camera.fy() * inv_z,
        -(du * camera.fx() * pc.x() + dv * camera.fy() * pc.y()) * inv_z * inv_z);
    const Eigen::RowVector3d d_x = sqrt_weight_ * slope * (d_pc * rcf);  // per fixed-frame point
    Eigen::Matrix3d skew;
    skew << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    const Eigen::RowVector3d d_w = -d_x * skew * left_jacobian;
    row[0] = d_w[0];
    row[1] = d_w[1];
    row[2] = d_w[2];
    row[3] = d_x[0];
    row[4] = d_x[1];
    row[5] = d_x[2];
  }
  return true;
}

}  // namespace registration
}  // namespace fluoro_tracker
