#include "fluoro_tracker/constraints/glenohumeral_springs.h"

#include <algorithm>

namespace fluoro_tracker {
namespace constraints {

double glenohumeralEnvelopeViolation(const LigamentSettings& settings,
                                     const geometry::Pose& scapula, const geometry::Pose& humerus,
                                     kinematics::Side side) {
  LigamentSettings unit = settings;
  unit.stiffness_per_deg = 1.0;
  unit.stiffness_per_mm = 1.0;
  const geometry::Pose relative = scapula.inverse() * humerus;
  Eigen::Matrix3d r = relative.linear();
  Eigen::Vector3d t = relative.translation();
  kinematics::glenohumeralAsRight(side, &r, &t);
  double residuals[6];
  glenohumeralSpringResiduals(unit, r, t, residuals);
  double worst = 0.0;
  for (double residual : residuals) worst = std::max(worst, std::abs(residual));
  return worst;
}

}  // namespace constraints
}  // namespace fluoro_tracker
