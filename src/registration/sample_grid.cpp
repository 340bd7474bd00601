#include "fluoro_tracker/registration/sample_grid.h"

#include <cmath>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace registration {

SampleGrid::SampleGrid(const std::vector<Eigen::Vector2d>& positions, const Eigen::Vector2d& origin,
                       double cell_size, int cols, int rows)
    : origin_(origin),
      cell_size_(cell_size),
      cols_(cols),
      rows_(rows),
      cell_of_point_(positions.size(), -1) {
  if (!(cell_size > 0.0) || cols <= 0 || rows <= 0) {
    throw InputError("sample grid: needs a positive cell size and at least one cell");
  }
  cell_start_.assign(static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows) + 1, 0);
  for (std::size_t i = 0; i < positions.size(); ++i) {
    cell_of_point_[i] = cellOf(positions[i]);
    if (cell_of_point_[i] >= 0) ++cell_start_[static_cast<std::size_t>(cell_of_point_[i]) + 1];
  }
  for (std::size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
  point_of_slot_.resize(static_cast<std::size_t>(cell_start_.back()));
  position_of_slot_.resize(point_of_slot_.size());
  std::vector<int> next(cell_start_.begin(), cell_start_.end() - 1);
  for (std::size_t i = 0; i < positions.size(); ++i) {
    if (cell_of_point_[i] < 0) continue;
    const auto slot = static_cast<std::size_t>(next[static_cast<std::size_t>(cell_of_point_[i])]++);
    point_of_slot_[slot] = static_cast<int>(i);
    position_of_slot_[slot] = positions[i];
  }
}

int SampleGrid::cellOf(const Eigen::Vector2d& position) const {
  const double x = position.x() - origin_.x();
  const double y = position.y() - origin_.y();
  // Negated tests so that NaN falls outside.
  if (!(x >= 0.0 && y >= 0.0)) return -1;
  const double cu = std::floor(x / cell_size_);
  const double cv = std::floor(y / cell_size_);
  if (!(cu < cols_ && cv < rows_)) return -1;
  return static_cast<int>(cv) * cols_ + static_cast<int>(cu);
}

}  // namespace registration
}  // namespace fluoro_tracker
