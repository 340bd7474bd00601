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
  std::vector<std::vector<int>> cells(static_cast<std::size_t>(cols * rows));
  for (std::size_t j = 0; j < contour.size(); ++j) {
    const auto [cu, cv] = cell_of(contour[j].pixel);
    cells[static_cast<std::size_t>(cv * cols + cu)].push_back(static_cast<int>(j));
  }
  for (std::size_t i = 0; i < contour.size(); ++i) {
    const auto [cu, cv] = cell_of(contour[i].pixel);
    double nearest = radius * radius;
    int other = -1;
    for (int gv = std::max(0, cv - 1); gv <= std::min(rows - 1, cv + 1); ++gv) {
      for (int gu = std::max(0, cu - 1); gu <= std::min(cols - 1, cu + 1); ++gu) {
        for (const int k : cells[static_cast<std::size_t>(gv * cols + gu)]) {
          const double squared = (contour[k].pixel - contour[i].pixel).squaredNorm();
          if (squared < nearest && contour[k].normal.dot(contour[i].normal) < min_cos) {
            nearest = squared;
            other = k;
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
