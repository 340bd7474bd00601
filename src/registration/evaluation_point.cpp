#include "fluoro_tracker/registration/evaluation_point.h"

#include <algorithm>
#include <numeric>
#include <utility>

namespace fluoro_tracker {
namespace registration {

EvaluationPoint::EvaluationPoint(std::vector<int> block_sizes)
    : block_sizes_(std::move(block_sizes)),
      values_(
          static_cast<std::size_t>(std::accumulate(block_sizes_.begin(), block_sizes_.end(), 0))) {}

bool EvaluationPoint::moved(double const* const* parameters) {
  bool same = stored_;
  std::size_t offset = 0;
  for (std::size_t k = 0; k < block_sizes_.size(); ++k) {
    const double* block = parameters[k];
    double* stored = values_.data() + offset;
    same = same && std::equal(block, block + block_sizes_[k], stored);
    std::copy(block, block + block_sizes_[k], stored);
    offset += static_cast<std::size_t>(block_sizes_[k]);
  }
  stored_ = true;
  return !same;
}

}  // namespace registration
}  // namespace fluoro_tracker
