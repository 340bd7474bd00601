#include "fluoro_tracker/registration/edge_to_contour_cost.h"

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
      robust_scale_(robust_scale_px),
      sqrt_weight_(std::sqrt(weight)) {
  set_num_residuals(static_cast<int>(pairs_.size()));
  mutable_parameter_block_sizes()->push_back(6);
}

bool EdgeToContourCost::Evaluate(double const* const* parameters, double* residuals,
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
  double* jac = (jacobians != nullptr) ? jacobians[0] : nullptr;

  for (std::size_t i = 0; i < pairs_.size(); ++i) {
    const Pair& pair = pairs_[i];
    const Eigen::Vector3d v = r * (pair.contour_point_fixed - centre_);
    const Eigen::Vector3d pc = rcf * (v + centre_ + t) + tcf;
    if (!(pc.z() > 0.0)) {
      residuals[i] = 0.0;
      if (jac != nullptr) std::fill(jac + 6 * i, jac + 6 * i + 6, 0.0);
      continue;
    }
    const double inv_z = 1.0 / pc.z();
    const Eigen::Vector2d u(camera_.fx() * pc.x() * inv_z + camera_.cx(),
                            camera_.fy() * pc.y() * inv_z + camera_.cy());
    const double distance = pair.normal.dot(pair.edge_pixel - u);
    double slope = 0.0;
    residuals[i] =
        sqrt_weight_ * ContourDistanceCost::robustResidual(distance, robust_scale_, &slope);
    if (jac == nullptr) continue;
    // d(distance)/d(pc) = -n^T d(u)/d(pc).
    const Eigen::RowVector3d d_pc(
        -pair.normal.x() * camera_.fx() * inv_z, -pair.normal.y() * camera_.fy() * inv_z,
        (pair.normal.x() * camera_.fx() * pc.x() + pair.normal.y() * camera_.fy() * pc.y()) *
            inv_z * inv_z);
    const Eigen::RowVector3d d_x = sqrt_weight_ * slope * (d_pc * rcf);
    Eigen::Matrix3d skew;
    skew << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    const Eigen::RowVector3d d_w = -d_x * skew * left_jacobian;
    double* row = jac + 6 * i;
    for (int k = 0; k < 3; ++k) {
      row[k] = d_w[k];
      row[3 + k] = d_x[k];
    }
  }
  return true;
}

}  // namespace registration
}  // namespace fluoro_tracker
