#pragma once

#include <cmath>

namespace fluoro_tracker {
namespace registration {

// The Cauchy kernel of the image terms as a residual: rho(s) = b^2 log(1 + s / b^2) for a
// signed distance d, residual sign(d) sqrt(rho(d^2)), smooth through zero and whose square is rho
// whatever the sign. Inline, with the scale's inverse kept, so that a sample costs one division
// and one square root: the kernel runs once per contour sample and cost evaluation, and its
// divisions' latency was the largest single share of a registration's time (perf, crude
// starts: 13 %). Measured (`taskset -c 1 benchmark --protocol crude --conditions
// contact+ligaments`, three runs each, alternately): median 33.3 -> 31.8 ms, identical results.
class CauchyResidual {
 public:
  explicit CauchyResidual(double scale) : scale_(scale), inverse_scale_(1.0 / scale) {}

  // The residual of distance `d`, and d(residual)/d(d) in `derivative`.
  double operator()(double d, double* derivative) const {
    const double ratio = d * inverse_scale_;
    if (std::abs(ratio) < 1e-6) {
      *derivative = 1.0;
      return d;
    }
    // log1p was a tenth of a registration's time: log(1 + q) is cheaper and as exact where q is
    // not small, and below 0.01 three terms of its series are exact to 3e-7 relative.
    const double q = ratio * ratio;
    const double log1p_q = q < 1e-2 ? q * (1.0 - q * (0.5 - q * (1.0 / 3.0))) : std::log(1.0 + q);
    const double root = std::sqrt(log1p_q);
    // d / (r (1 + q)) with r = sign(d) b root.
    *derivative = std::abs(ratio) / (root * (1.0 + q));
    return std::copysign(scale_ * root, d);
  }

 private:
  double scale_;
  double inverse_scale_;
};

}  // namespace registration
}  // namespace fluoro_tracker
