#include "fluoro_tracker/registration/corner_rounding.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <boost/math/special_functions/erf.hpp>

#include "fluoro_tracker/registration/sample_grid.h"

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
  std::vector<Eigen::Vector2d> positions(contour.size());
  for (std::size_t j = 0; j < contour.size(); ++j) positions[j] = contour[j].pixel;
  const SampleGrid grid(positions, box.min(), radius,
                        static_cast<int>(box.sizes().x() / radius) + 1,
                        static_cast<int>(box.sizes().y() / radius) + 1);
  // Normals in slot order, read in sequence with the positions by the search below.
  std::vector<Eigen::Vector2d> normal_of_slot(static_cast<std::size_t>(grid.slots()));
  for (int s = 0; s < grid.slots(); ++s) {
    normal_of_slot[static_cast<std::size_t>(s)] =
        contour[static_cast<std::size_t>(grid.point(s))].normal;
  }
  for (std::size_t i = 0; i < contour.size(); ++i) {
    const int cu = grid.cellOfPoint(i) % grid.cols();
    const int cv = grid.cellOfPoint(i) / grid.cols();
    const Eigen::Vector2d& p = contour[i].pixel;
    const Eigen::Vector2d& n = contour[i].normal;
    double nearest = radius * radius;
    int other = -1;
    for (int gv = std::max(0, cv - 1); gv <= std::min(grid.rows() - 1, cv + 1); ++gv) {
      for (int gu = std::max(0, cu - 1); gu <= std::min(grid.cols() - 1, cu + 1); ++gu) {
        const int g = gv * grid.cols() + gu;
        for (int s = grid.begin(g); s < grid.end(g); ++s) {
          const Eigen::Vector2d& q = grid.position(s);
          const Eigen::Vector2d& m = normal_of_slot[static_cast<std::size_t>(s)];
          const double du = q.x() - p.x();
          const double dv = q.y() - p.y();
          const double squared = du * du + dv * dv;
          if (squared < nearest && m.x() * n.x() + m.y() * n.y() < min_cos) {
            nearest = squared;
            other = grid.point(s);
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
