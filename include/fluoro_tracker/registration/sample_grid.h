#pragma once

#include <vector>

#include <Eigen/Core>

namespace fluoro_tracker {
namespace registration {

// Points (e.g. a projected contour's samples) bucketed in square cells by a counting sort, so
// that a search for the points near a position visits only its own and the neighbouring cells
// instead of every point. Cells are numbered row by row; a cell's points keep their input order.
class SampleGrid {
 public:
  // Cell (cu, cv) covers origin + [cu, cu + 1) x [cv, cv + 1) times `cell_size`. Positions that
  // are not finite or fall outside the cols x rows cells are left out.
  SampleGrid(const std::vector<Eigen::Vector2d>& positions, const Eigen::Vector2d& origin,
             double cell_size, int cols, int rows);

  int cols() const { return cols_; }
  int rows() const { return rows_; }

  // The cell of a position, or -1 outside the grid.
  int cellOf(const Eigen::Vector2d& position) const;
  // The cell of input point i, or -1 if it was left out.
  int cellOfPoint(std::size_t i) const { return cell_of_point_[i]; }
  bool empty(int cell) const { return begin(cell) == end(cell); }

  // Cell c's points are the slots begin(c) .. end(c) - 1, and each slot's point is
  // point(slot), at position(slot): positions are stored in slot order so that a scan of a
  // cell reads them in sequence.
  int begin(int cell) const { return cell_start_[static_cast<std::size_t>(cell)]; }
  int end(int cell) const { return cell_start_[static_cast<std::size_t>(cell) + 1]; }
  int point(int slot) const { return point_of_slot_[static_cast<std::size_t>(slot)]; }
  const Eigen::Vector2d& position(int slot) const {
    return position_of_slot_[static_cast<std::size_t>(slot)];
  }
  int slots() const { return static_cast<int>(point_of_slot_.size()); }

 private:
  Eigen::Vector2d origin_;
  double cell_size_;
  int cols_;
  int rows_;
  std::vector<int> cell_of_point_;
  std::vector<int> cell_start_;  // per cell and one past the last: its first slot
  std::vector<int> point_of_slot_;
  std::vector<Eigen::Vector2d> position_of_slot_;
};

}  // namespace registration
}  // namespace fluoro_tracker
