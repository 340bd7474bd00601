#include "fluoro_tracker/registration/sample_grid.h"

#include <gtest/gtest.h>

#include <limits>
#include <set>
#include <vector>

#include "fluoro_tracker/input_error.h"

using namespace fluoro_tracker;
using registration::SampleGrid;

TEST(SampleGrid, BucketsPointsByCellInInputOrder) {
  const Eigen::Vector2d origin(10.0, 20.0);
  // Cells of 2 px, 3 x 2 of them: x in [10, 16), y in [20, 24).
  const std::vector<Eigen::Vector2d> points = {
      {11.0, 21.0},  // cell (0, 0)
      {15.9, 23.9},  // cell (2, 1)
      {10.0, 20.0},  // cell (0, 0), on its corner
      {12.0, 21.5},  // cell (1, 0), on its left border
      {11.5, 22.0},  // cell (0, 1)
  };
  const SampleGrid grid(points, origin, 2.0, 3, 2);
  ASSERT_EQ(grid.slots(), 5);
  EXPECT_EQ(grid.cellOfPoint(0), 0);
  EXPECT_EQ(grid.cellOfPoint(1), 1 * 3 + 2);
  EXPECT_EQ(grid.cellOfPoint(2), 0);
  EXPECT_EQ(grid.cellOfPoint(3), 1);
  EXPECT_EQ(grid.cellOfPoint(4), 3);
  // Cell 0 holds points 0 and 2, in that order, with their positions.
  ASSERT_EQ(grid.end(0) - grid.begin(0), 2);
  EXPECT_EQ(grid.point(grid.begin(0)), 0);
  EXPECT_EQ(grid.point(grid.begin(0) + 1), 2);
  EXPECT_EQ(grid.position(grid.begin(0) + 1), points[2]);
  EXPECT_TRUE(grid.empty(2));
  EXPECT_FALSE(grid.empty(5));
  // Every point sits in exactly one slot, within its own cell's range.
  std::set<int> seen;
  for (int cell = 0; cell < grid.cols() * grid.rows(); ++cell) {
    for (int slot = grid.begin(cell); slot < grid.end(cell); ++slot) {
      EXPECT_EQ(grid.cellOfPoint(static_cast<std::size_t>(grid.point(slot))), cell);
      seen.insert(grid.point(slot));
    }
  }
  EXPECT_EQ(seen.size(), points.size());
}

TEST(SampleGrid, LeavesOutPointsOutsideItsCellsAndNonFiniteOnes) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Eigen::Vector2d> points = {
      {-0.1, 1.0},  // left of the grid
      {1.0, 4.0},   // below its last row: rows cover y in [0, 4)
      {nan, 1.0},
      {1.0, 1.0},  // kept
  };
  const SampleGrid grid(points, Eigen::Vector2d::Zero(), 2.0, 2, 2);
  EXPECT_EQ(grid.slots(), 1);
  EXPECT_EQ(grid.cellOfPoint(0), -1);
  EXPECT_EQ(grid.cellOfPoint(1), -1);
  EXPECT_EQ(grid.cellOfPoint(2), -1);
  EXPECT_EQ(grid.cellOfPoint(3), 0);
  EXPECT_EQ(grid.cellOf(Eigen::Vector2d(3.9, 3.9)), 3);
  EXPECT_EQ(grid.cellOf(Eigen::Vector2d(4.0, 0.0)), -1);
}

TEST(SampleGrid, RejectsAnEmptyGrid) {
  EXPECT_THROW(SampleGrid({}, Eigen::Vector2d::Zero(), 0.0, 1, 1), InputError);
  EXPECT_THROW(SampleGrid({}, Eigen::Vector2d::Zero(), 1.0, 0, 1), InputError);
}
