#pragma once

#include <vector>

namespace fluoro_tracker {
namespace registration {

// The parameter values a cost function was last evaluated at. After an accepted step Ceres
// evaluates the Jacobian at the candidate it has just costed without one: a cost that keeps its
// per-sample work (ContourDistanceCost: its edge-map look-ups) can reuse it when the point has not
// moved (EdgeToContourCost keeps its residuals and slopes the same way). (Tried on the contact
// cost's distance-grid look-ups too: 0.7 % fewer instructions, since the cost alone then needs the
// grid's gradients as well; not kept.)
class EvaluationPoint {
 public:
  explicit EvaluationPoint(std::vector<int> block_sizes);

  // Whether `parameters` (one array per block) differ from the last call's, always true on the
  // first call (and for NaN values); remembers them.
  bool moved(double const* const* parameters);

 private:
  std::vector<int> block_sizes_;
  std::vector<double> values_;
  bool stored_ = false;
};

}  // namespace registration
}  // namespace fluoro_tracker
