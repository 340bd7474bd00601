#include "fluoro_tracker/registration/corner_rounding.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <boost/math/special_functions/erf.hpp>

namespace fluoro_tracker {
namespace registration {
namespace {

// A turn of more than this between two samples' normals makes a corner.
constexpr double kCornerTurnDeg = 30.0;

double normalCdf(double x) {
  return 0.5 * std::erfc(-x / std::sqrt(2.0));
}

double inverseNormalCdf(double p) {
  return -std::sqrt(2.0) * boost::math::erfc_inv(2.0 * p);
}

}  // namespace

std::vector<double> cornerRounding(const std::vector<imaging::ContourPoint>& contour,
                                   double sigma_px) {
  std::vector<double> rounding(contour.size(), 0.0);
  if (!(sigma_px > 0.0) || contour.empty()) return rounding;
  const double min_cos = std::cos(kCornerTurnDeg * M_PI / 180.0);
  // The samples bucketed in cells of the search radius, so each compares only its 3 x 3 cells.
  const double radius = 3.0 * sigma_px;
  Eigen::AlignedBox2d box;
  for (const auto& c : contour) box.extend(c.pixel);
  const int cols = static_cast<int>(box.sizes().x() / radius) + 1;
  const int rows = static_cast<int>(box.sizes().y() / radius) + 1;
  const auto cell_of = [&](const Eigen::Vector2d& p) {
    const int cu = std::clamp(static_cast<int>((p.x() - box.min().x()) / radius), 0, cols - 1);
    const int cv = std::clamp(static_cast<int>((p.y() - box.min().y()) / radius), 0, rows - 1);
    return std::pair<int, int>(cu, cv);
  };
  // A counting sort: cell_start[c] .. cell_start[c + 1] index the samples of cell c.
  std::vector<int> cell_start(static_cast<std::size_t>(cols * rows) + 1, 0);
  std::vector<int> cell_of_sample(contour.size());
  for (std::size_t j = 0; j < contour.size(); ++j) {
    const auto [cu, cv] = cell_of(contour[j].pixel);
    cell_of_sample[j] = cv * cols + cu;
    ++cell_start[static_cast<std::size_t>(cell_of_sample[j]) + 1];
  }
  for (std::size_t c = 1; c < cell_start.size(); ++c) cell_start[c] += cell_start[c - 1];
  // Positions and normals in cell order, read in sequence by the search below.
  std::vector<int> samples_by_cell(contour.size());
  std::vector<Eigen::Vector4d> by_cell(contour.size());  // pixel, normal
  {
    std::vector<int> next(cell_start.begin(), cell_start.end() - 1);
    for (std::size_t j = 0; j < contour.size(); ++j) {
      const auto slot = static_cast<std::size_t>(next[cell_of_sample[j]]++);
      samples_by_cell[slot] = static_cast<int>(j);
      by_cell[slot] << contour[j].pixel, contour[j].normal;
    }
  }
  for (std::size_t i = 0; i < contour.size(); ++i) {
    const int cu = cell_of_sample[i] % cols;
    const int cv = cell_of_sample[i] / cols;
    const Eigen::Vector2d& p = contour[i].pixel;
    const Eigen::Vector2d& n = contour[i].normal;
    double nearest = radius * radius;
    int other = -1;
    for (int gv = std::max(0, cv - 1); gv <= std::min(rows - 1, cv + 1); ++gv) {
      for (int gu = std::max(0, cu - 1); gu <= std::min(cols - 1, cu + 1); ++gu) {
        const int g = gv * cols + gu;
        for (int s = cell_start[static_cast<std::size_t>(g)];
             s < cell_start[static_cast<std::size_t>(g) + 1]; ++s) {
          const Eigen::Vector4d& q = by_cell[static_cast<std::size_t>(s)];
          const double du = q[0] - p.x();
          const double dv = q[1] - p.y();
          const double squared = du * du + dv * dv;
          if (squared < nearest && q[2] * n.x() + q[3] * n.y() < min_cos) {
            nearest = squared;
            other = samples_by_cell[static_cast<std::size_t>(s)];
          }
        }
      }
    }
    if (other < 0) continue;
    // The sample's distance into the other half-plane (normals point out of the silhouette).
    const double b = -contour[other].normal.dot(contour[i].pixel - contour[other].pixel);
    const double level = 0.5 / normalCdf(std::abs(b) / sigma_px);  // in (0.5, 1]
    const double a = level >= 1.0 ? sigma_px : sigma_px * inverseNormalCdf(level);
    rounding[i] = std::min(a, sigma_px) * (b >= 0.0 ? 1.0 : -1.0);
  }
  return rounding;
}

}  // namespace registration
}  // namespace fluoro_tracker
