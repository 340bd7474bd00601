#include "fluoro_tracker/constraints/glenohumeral_springs.h"

namespace fluoro_tracker {
namespace constraints {

double glenohumeralEnvelopeViolation(const LigamentSettings& settings,
                                     const geometry::Pose& scapula, const geometry::Pose& humerus,
                                     kinematics::Side side) {
  const geometry::Pose relative = scapula.inverse() * humerus;
  Eigen::Matrix3d r = relative.linear();
  Eigen::Vector3d t = relative.translation();
  kinematics::glenohumeralAsRight(side, &r, &t);
  return largestExcess(settings, [&](const LigamentSettings& unit, double residuals[6]) {
    glenohumeralSpringResiduals(unit, r, t, residuals);
  });
}

}  // namespace constraints
}  // namespace fluoro_tracker
