// The only translation unit that builds Ceres problems for image registration.
#include "fluoro_tracker/registration/registrar.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <deque>
#include <exception>
#include <initializer_list>
#include <limits>
#include <map>
#include <optional>

#include <ceres/ceres.h>
#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/parallel_for.h"
#include "fluoro_tracker/registration/compressed_residuals_cost.h"
#include "fluoro_tracker/registration/contact_cost.h"
#include "fluoro_tracker/registration/contour_distance_cost.h"
#include "fluoro_tracker/registration/corner_rounding.h"
#include "fluoro_tracker/registration/edge_map_prefetch.h"
#include "fluoro_tracker/registration/edge_to_contour_cost.h"
#include "fluoro_tracker/registration/image_shift_search.h"
#include "fluoro_tracker/registration/ligament_cost.h"
#include "fluoro_tracker/registration/mirror_ambiguity.h"
#include "fluoro_tracker/registration/parent_relative_cost.h"
#include "fluoro_tracker/registration/pose_increment.h"
#include "fluoro_tracker/registration/rendered_edges.h"
#include "fluoro_tracker/registration/sample_grid.h"

namespace fluoro_tracker {
namespace registration {
namespace {

// Copies of a frame's maps for a solve on another thread (EdgeMap::unshared).
std::vector<imaging::EdgeMap> unsharedMaps(const std::vector<imaging::EdgeMap>& maps) {
  std::vector<imaging::EdgeMap> copies;
  for (const imaging::EdgeMap& map : maps) copies.push_back(map.unshared());
  return copies;
}

// Extends `box` by the projections of the corners of the bone's bounding box at `pose`;
// false if a corner lies closer than `min_depth_m` to the view's source plane (or behind it).
bool extendByProjectedBounds(const geometry::XrayCamera& camera, const BoneModel& bone,
                             const geometry::Pose& pose, double min_depth_m,
                             Eigen::AlignedBox2d* box) {
  const geometry::Pose camera_from_bone = camera.worldFromCamera().inverse() * pose;
  const Eigen::AlignedBox3d& bounds = bone.silhouette->bounds();
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d p =
        camera_from_bone * bounds.corner(static_cast<Eigen::AlignedBox3d::CornerType>(corner));
    Eigen::Vector2d px;
    if (p.z() < min_depth_m || !camera.project(p, &px)) return false;
    box->extend(px);
  }
  return true;
}

// Pixel rectangle of a view covering every bone's projected bounding box, plus a margin.
cv::Rect regionOfInterest(const geometry::XrayCamera& camera, const std::vector<BoneModel>& bones,
                          const std::vector<geometry::Pose>& poses, double margin) {
  Eigen::AlignedBox2d box;
  for (std::size_t b = 0; b < bones.size(); ++b) {
    if (!extendByProjectedBounds(camera, bones[b], poses[b], 0.0, &box)) {
      throw InputError("registration: bone '" + bones[b].name +
                       "' lies behind the X-ray source of " + camera.frameId());
    }
  }
  const int x0 = static_cast<int>(std::floor(box.min().x() - margin));
  const int y0 = static_cast<int>(std::floor(box.min().y() - margin));
  const int x1 = static_cast<int>(std::ceil(box.max().x() + margin));
  const int y1 = static_cast<int>(std::ceil(box.max().y() + margin));
  return cv::Rect(x0, y0, x1 - x0, y1 - y0) & cv::Rect(0, 0, camera.width(), camera.height());
}

// Cost evaluations and iterations of a registration plus the extra solves made for it (mirror
// check, depth retry), whichever of them is kept.
struct SolveCounts {
  int cost_evaluations = 0;
  int solver_iterations = 0;
  int outer_iterations = 0;
  explicit SolveCounts(const RegistrationResult& first) { add(first); }
  void add(const RegistrationResult& solve) {
    cost_evaluations += solve.cost_evaluations;
    solver_iterations += solve.solver_iterations;
    outer_iterations += solve.outer_iterations;
  }
  void writeTo(RegistrationResult* result) const {
    result->cost_evaluations = cost_evaluations;
    result->solver_iterations = solver_iterations;
    result->outer_iterations = outer_iterations;
  }
};

// True if the bone's bounding box lies in front of every view's source and overlaps its image.
bool isViewable(const BoneModel& bone, const geometry::Pose& pose,
                const std::vector<ViewImage>& views) {
  for (const auto& view : views) {
    Eigen::AlignedBox2d box;
    if (!extendByProjectedBounds(view.camera, bone, pose, 0.01, &box)) return false;
    const Eigen::AlignedBox2d image(Eigen::Vector2d(0.0, 0.0),
                                    Eigen::Vector2d(view.camera.width(), view.camera.height()));
    if (!box.intersects(image)) return false;
  }
  return true;
}

// Image motion of a contour point per pixel of edge offset (see EdgeOffsetModel): inward.
Eigen::Vector2d offsetDirection(const imaging::ContourPoint& c,
                                RegistrationSettings::EdgeOffsetModel model) {
  return model == RegistrationSettings::EdgeOffsetModel::kUniform ? Eigen::Vector2d(-c.normal)
                                                                  : Eigen::Vector2d::Zero();
}

// Pairs image edge pixels within `band` pixels of a projected contour with their nearest
// contour sample (Euclidean, to the sample's sub-pixel position), taking at most `max_pairs`
// edges spread evenly in raster order.
std::vector<EdgeToContourCost::Pair> edgeContourPairs(
    const imaging::EdgeMap& map, const std::vector<imaging::ContourPoint>& contour,
    const geometry::Pose& pose, double band, std::size_t max_pairs,
    RegistrationSettings::EdgeOffsetModel model, const std::vector<double>& rounding) {
  // Work in the crop around the contour that the band can reach.
  Eigen::AlignedBox2d box;
  for (const auto& c : contour) box.extend(c.pixel);
  const int margin = static_cast<int>(std::ceil(band)) + 2;
  const cv::Rect crop =
      cv::Rect(cv::Point(static_cast<int>(std::floor(box.min().x())) - margin,
                         static_cast<int>(std::floor(box.min().y())) - margin),
               cv::Point(static_cast<int>(std::ceil(box.max().x())) + margin + 1,
                         static_cast<int>(std::ceil(box.max().y())) + margin + 1)) &
      cv::Rect(0, 0, map.edges().cols, map.edges().rows);
  if (crop.area() == 0) return {};
  const cv::Mat edges = map.edges()(crop);
  // The samples bucketed in band-sized cells, so that each edge pixel compares only the samples
  // of its 3 x 3 cells. (A labelled distance transform of the crop, per bone and outer
  // iteration, took about 0.3 ms: a sixth of the image-only registration's time.)
  const int cell = std::max(1, static_cast<int>(std::ceil(band)));
  const int grid_cols = crop.width / cell + 1;
  const int grid_rows = crop.height / cell + 1;
  // Sample positions in the crop; those outside it are left out of the grid.
  std::vector<Eigen::Vector2d> in_crop(contour.size());
  for (std::size_t j = 0; j < contour.size(); ++j) {
    in_crop[j] = contour[j].pixel - Eigen::Vector2d(crop.x, crop.y);
    if (!(in_crop[j].x() < crop.width && in_crop[j].y() < crop.height)) {
      in_crop[j].setConstant(std::numeric_limits<double>::quiet_NaN());
    }
  }
  const SampleGrid grid(in_crop, Eigen::Vector2d::Zero(), cell, grid_cols, grid_rows);
  // Cells with a sample in their 3 x 3 neighbourhood: edge pixels elsewhere (most of the bone's
  // interior and background) are skipped without visiting the cells.
  std::vector<std::uint8_t> near_samples(static_cast<std::size_t>(grid_cols * grid_rows), 0);
  for (int gv = 0; gv < grid_rows; ++gv) {
    for (int gu = 0; gu < grid_cols; ++gu) {
      if (grid.empty(gv * grid_cols + gu)) continue;
      for (int nv = std::max(0, gv - 1); nv <= std::min(grid_rows - 1, gv + 1); ++nv) {
        for (int nu = std::max(0, gu - 1); nu <= std::min(grid_cols - 1, gu + 1); ++nu) {
          near_samples[nv * grid_cols + nu] = 1;
        }
      }
    }
  }
  struct Candidate {
    int u;
    int v;
    int sample;
  };
  std::vector<Candidate> candidates;
  const double band_squared = band * band;
  for (int v = 0; v < edges.rows; ++v) {
    const std::uint8_t* e = edges.ptr<std::uint8_t>(v);
    const int cell_v = v / cell;
    const std::uint8_t* near_row = near_samples.data() + cell_v * grid_cols;
    for (int u = 0; u < edges.cols; ++u) {
      // Edge pixels are a few per cent of the crop: eight at a time are skipped while none is set.
      if (u + 8 <= edges.cols) {
        std::uint64_t eight;
        std::memcpy(&eight, e + u, sizeof(eight));
        if (eight == 0) {
          u += 7;
          continue;
        }
      }
      if (e[u] == 0) continue;
      const int cell_u = u / cell;
      if (near_row[cell_u] == 0) continue;
      const auto squared_distance = [&](int slot) {
        const double du = grid.position(slot).x() - u;
        const double dv = grid.position(slot).y() - v;
        return du * du + dv * dv;
      };
      // A bound from the pixel's own cell first, so that the 3 x 3 scan below skips the cells
      // that lie wholly farther away. The scan keeps its order and its rule (the last of equally
      // near samples wins), so the pairs are those of a full scan.
      double bound = band_squared;
      const int own = cell_v * grid_cols + cell_u;
      for (int slot = grid.begin(own); slot < grid.end(own); ++slot) {
        bound = std::min(bound, squared_distance(slot));
      }
      double best = band_squared;
      int nearest = -1;
      for (int gv = std::max(0, cell_v - 1); gv <= std::min(grid_rows - 1, cell_v + 1); ++gv) {
        const double dv = gv < cell_v   ? v - cell_v * cell
                          : gv > cell_v ? (cell_v + 1) * cell - v
                                        : 0.0;
        for (int gu = std::max(0, cell_u - 1); gu <= std::min(grid_cols - 1, cell_u + 1); ++gu) {
          const double du = gu < cell_u   ? u - cell_u * cell
                            : gu > cell_u ? (cell_u + 1) * cell - u
                                          : 0.0;
          if (du * du + dv * dv > bound) continue;
          const int g = gv * grid_cols + gu;
          for (int slot = grid.begin(g); slot < grid.end(g); ++slot) {
            const double squared = squared_distance(slot);
            if (squared <= best) {
              best = squared;
              nearest = grid.point(slot);
            }
          }
        }
      }
      if (nearest >= 0) candidates.push_back({u, v, nearest});
    }
  }
  const std::size_t stride = std::max<std::size_t>(
      1, (candidates.size() + max_pairs - 1) / std::max<std::size_t>(1, max_pairs));
  std::vector<EdgeToContourCost::Pair> pairs;
  for (std::size_t k = 0; k < candidates.size(); k += stride) {
    const Candidate& c = candidates[k];
    const imaging::ContourPoint& sample = contour[c.sample];
    pairs.push_back({pose * sample.model_point, sample.normal,
                     map.edgePoint(c.u + crop.x, c.v + crop.y),
                     sample.normal.dot(offsetDirection(sample, model)), rounding[c.sample]});
  }
  return pairs;
}

// How far below RegistrationSettings::edge_offset_min_px an offset may sink per unit of
// residual (full-resolution pixels), a tenth of the offset prior's sigma. One offset per bone
// is a compromise over its outline, so the image can still pull it a few tenths of a pixel
// below the floor (the Kneel study's tray seen 8 deg obliquely: -0.33 px, 3.3 mm along the
// beam, where the unbounded offset went to -0.62 px and 8.6 mm); a stiffer floor (0.02, 0.01
// px) pushed that tray 2-3.5 mm the other way.
constexpr double kEdgeOffsetFloorSigmaPx = 0.05;

// Gaussian prior on an edge offset: residual (offset - mean) / sigma.
class EdgeOffsetPriorCost : public ceres::SizedCostFunction<1, 1> {
 public:
  EdgeOffsetPriorCost(double mean, double inverse_sigma)
      : mean_(mean), inverse_sigma_(inverse_sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    residuals[0] = inverse_sigma_ * (parameters[0][0] - mean_);
    if (jacobians != nullptr && jacobians[0] != nullptr) jacobians[0][0] = inverse_sigma_;
    return true;
  }

 private:
  double mean_;
  double inverse_sigma_;
};

// A floor under an edge offset (RegistrationSettings::edge_offset_min_px): residual
// (floor - offset) / sigma below it, zero above, so the cost's gradient is continuous through
// it. A soft floor rather than a Ceres bound: projected Levenberg-Marquardt steps against a
// bound converged slowly (p95 time per frame doubled).
class EdgeOffsetFloorCost : public ceres::SizedCostFunction<1, 1> {
 public:
  EdgeOffsetFloorCost(double floor, double inverse_sigma)
      : floor_(floor), inverse_sigma_(inverse_sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const bool below = parameters[0][0] < floor_;
    residuals[0] = below ? inverse_sigma_ * (floor_ - parameters[0][0]) : 0.0;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      jacobians[0][0] = below ? -inverse_sigma_ : 0.0;
    }
    return true;
  }

 private:
  double floor_;
  double inverse_sigma_;
};

constexpr int kOffsetPatterns = 2;  // the offset gradient's two axes

// One bone's contour term in one view as the covariance's offset-gradient allowance sees it
// (RegistrationSettings::covariance_offset_gradient_sd_px): the term's cost (owned by the
// problem), its parameter blocks, and per sample where along the outline's two principal axes
// it lies, from -1 to 1 (the offset's change per unit of gradient).
struct OffsetGradientTerm {
  std::size_t bone = 0;
  const ceres::CostFunction* cost = nullptr;
  double* increment = nullptr;
  double* offset = nullptr;
  std::vector<Eigen::Vector2d> pattern;
};

// Each contour sample's offset per unit of gradient along the outline's two principal axes: its
// position along each axis, scaled to [-1, 1] (the offset's change from the centre to the end).
std::vector<Eigen::Vector2d> offsetGradientPattern(
    const std::vector<imaging::ContourPoint>& contour) {
  std::vector<Eigen::Vector2d> pattern(contour.size(), Eigen::Vector2d::Zero());
  if (contour.size() < 3) return pattern;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& c : contour) mean += c.pixel;
  mean /= static_cast<double>(contour.size());
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const auto& c : contour) scatter += (c.pixel - mean) * (c.pixel - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> axes(scatter);
  Eigen::Vector2d reach = Eigen::Vector2d::Zero();
  for (std::size_t k = 0; k < contour.size(); ++k) {
    pattern[k] = axes.eigenvectors().transpose() * (contour[k].pixel - mean);
    reach = reach.cwiseMax(pattern[k].cwiseAbs());
  }
  for (auto& f : pattern) {
    for (int a = 0; a < 2; ++a) f(a) = reach(a) > 0.0 ? f(a) / reach(a) : 0.0;
  }
  return pattern;
}

// Per bone, the covariance of its pose from the solved increments: Ceres' (J^T J)^-1 of the
// increment [w, t], scaled by the residual variance 2 cost / (residuals - parameters), then
// carried to ROS's ordering: the origin o moves by t - [o - c]x w, the rotation by w.
// `compressed_away`: residuals that Ceres does not count (CompressedResidualsCost).
// Also, into offset_gradient_covariances, how far an unknown edge-offset gradient of
// `gradient_sd` (map pixels) along each term's outline would move each bone: with H = J^T J and
// G the offset's Jacobian column weighted by the samples' pattern, the estimate moves by
// -H^+ J^T G per unit of gradient.
void estimateCovariances(ceres::Problem* problem, const ceres::Solver::Summary& summary,
                         int compressed_away, std::vector<std::array<double, 6>>& increments,
                         const std::vector<Eigen::Vector3d>& centres,
                         const std::vector<geometry::Pose>& poses,
                         const std::vector<int>& relative_parent,
                         const std::vector<OffsetGradientTerm>& gradient_terms, double gradient_sd,
                         RegistrationResult* result) {
  const std::size_t bones = increments.size();
  result->covariances.assign(bones, Eigen::Matrix<double, 6, 6>::Zero());
  result->offset_gradient_covariances.assign(bones, Eigen::Matrix<double, 6, 6>::Zero());
  result->covariance_valid.assign(bones, false);
  // (J^T J)^+ over every free parameter block (bones' increments and edge offsets) from one
  // evaluation of the robustified Jacobian: what ceres::Covariance's DENSE_SVD gives (the two
  // agreed to 1e-9 relative on the benchmark's frames) in a fraction of its time, since J has
  // thousands of rows and a dozen or two columns, so J^T J is formed directly and decomposed.
  std::vector<double*> all_blocks;
  problem->GetParameterBlocks(&all_blocks);
  std::vector<double*> free_blocks;
  for (double* block : all_blocks) {
    if (!problem->IsParameterBlockConstant(block)) free_blocks.push_back(block);
  }
  if (free_blocks.empty()) return;
  ceres::Problem::EvaluateOptions evaluate;
  evaluate.parameter_blocks = free_blocks;
  evaluate.apply_loss_function = true;
  evaluate.num_threads = 1;
  ceres::CRSMatrix jacobian;
  if (!problem->Evaluate(evaluate, nullptr, nullptr, nullptr, &jacobian)) return;
  std::map<const double*, int> column_of;
  int columns = 0;
  for (double* block : free_blocks) {
    column_of[block] = columns;
    columns += problem->ParameterBlockTangentSize(block);
  }
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(columns, columns);
  for (int row = 0; row < jacobian.num_rows; ++row) {
    const int begin = jacobian.rows[row];
    const int end = jacobian.rows[row + 1];
    for (int i = begin; i < end; ++i) {
      for (int j = i; j < end; ++j) {
        normal(jacobian.cols[i], jacobian.cols[j]) += jacobian.values[i] * jacobian.values[j];
      }
    }
  }
  normal = normal.selfadjointView<Eigen::Upper>();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(normal);
  if (eigen.info() != Eigen::Success) return;
  // Pseudo-inverse: directions the data do not constrain stay unbounded rather than invented.
  const double largest = eigen.eigenvalues().maxCoeff();
  Eigen::VectorXd inverse_values = Eigen::VectorXd::Zero(columns);
  for (int k = 0; k < columns; ++k) {
    const double value = eigen.eigenvalues()(k);
    if (value > 1e-14 * largest) inverse_values(k) = 1.0 / value;
  }
  const Eigen::MatrixXd inverse =
      eigen.eigenvectors() * inverse_values.asDiagonal() * eigen.eigenvectors().transpose();
  const int dof =
      summary.num_residuals_reduced + compressed_away - summary.num_effective_parameters_reduced;
  const double variance = dof > 0 ? 2.0 * summary.final_cost / dof : 1.0;
  // The offset gradients' effect on every free parameter: two columns per term.
  Eigen::MatrixXd gradient_effect;
  if (gradient_sd > 0.0 && !gradient_terms.empty()) {
    Eigen::MatrixXd cross = Eigen::MatrixXd::Zero(columns, kOffsetPatterns * gradient_terms.size());
    std::vector<double> residuals;
    std::vector<double> d_increment;
    std::vector<double> d_offset;
    for (std::size_t t = 0; t < gradient_terms.size(); ++t) {
      const OffsetGradientTerm& term = gradient_terms[t];
      const std::size_t n = term.pattern.size();
      const auto increment_column = column_of.find(term.increment);
      if (increment_column == column_of.end() ||
          static_cast<std::size_t>(term.cost->num_residuals()) != n) {
        continue;
      }
      // The term sees the bone's absolute increment; a parent-relative child's is composed.
      const int parent = relative_parent[term.bone];
      double absolute[6];
      Eigen::Matrix<double, 6, 6, Eigen::RowMajor> d_parent;
      Eigen::Matrix<double, 6, 6, Eigen::RowMajor> d_relative;
      auto parent_column = column_of.end();
      if (parent >= 0) {
        parent_column = column_of.find(increments[static_cast<std::size_t>(parent)].data());
        if (parent_column == column_of.end()) continue;
        composeRelativeIncrement(increments[static_cast<std::size_t>(parent)].data(),
                                 term.increment, centres[static_cast<std::size_t>(parent)],
                                 centres[term.bone], absolute, d_parent.data(), d_relative.data());
      } else {
        std::copy(term.increment, term.increment + 6, absolute);
      }
      residuals.resize(n);
      d_increment.resize(6 * n);
      d_offset.resize(n);
      const double* parameters[] = {absolute, term.offset};
      double* jacobians[] = {d_increment.data(), d_offset.data()};
      if (!term.cost->Evaluate(parameters, residuals.data(), jacobians)) continue;
      const auto offset_column = column_of.find(term.offset);
      for (int a = 0; a < kOffsetPatterns; ++a) {
        const Eigen::Index col = static_cast<Eigen::Index>(kOffsetPatterns * t) + a;
        Eigen::Matrix<double, 6, 1> along_increment = Eigen::Matrix<double, 6, 1>::Zero();
        for (std::size_t k = 0; k < n; ++k) {
          const double g = d_offset[k] * term.pattern[k](a);
          along_increment += g * Eigen::Map<const Eigen::Matrix<double, 6, 1>>(&d_increment[6 * k]);
          if (offset_column != column_of.end())
            cross(offset_column->second, col) += d_offset[k] * g;
        }
        if (parent >= 0) {
          cross.block<6, 1>(parent_column->second, col) += d_parent.transpose() * along_increment;
          cross.block<6, 1>(increment_column->second, col) +=
              d_relative.transpose() * along_increment;
        } else {
          cross.block<6, 1>(increment_column->second, col) += along_increment;
        }
      }
    }
    gradient_effect = gradient_sd * inverse * cross;
  }
  for (std::size_t b = 0; b < bones; ++b) {
    const double* block = increments[b].data();
    if (!problem->HasParameterBlock(block) || problem->IsParameterBlockConstant(block)) continue;
    const auto column = column_of.find(block);
    if (column == column_of.end()) continue;
    Eigen::Matrix<double, 6, 6> c = inverse.block<6, 6>(column->second, column->second);
    // The gradients' effect on this bone's increment (rows: its parameters).
    Eigen::MatrixXd effect;
    if (gradient_effect.size() > 0) effect = gradient_effect.middleRows(column->second, 6);
    if (relative_parent[b] >= 0) {
      // A parent-relative child: its absolute increment's covariance through the composition.
      const std::size_t p = static_cast<std::size_t>(relative_parent[b]);
      const auto parent_column = column_of.find(increments[p].data());
      if (parent_column == column_of.end()) continue;
      double absolute[6];
      Eigen::Matrix<double, 6, 12, Eigen::RowMajor> g;
      Eigen::Matrix<double, 6, 6, Eigen::RowMajor> d_parent;
      Eigen::Matrix<double, 6, 6, Eigen::RowMajor> d_relative;
      composeRelativeIncrement(increments[p].data(), block, centres[p], centres[b], absolute,
                               d_parent.data(), d_relative.data());
      g << d_parent, d_relative;
      Eigen::Matrix<double, 12, 12> joint;
      const int cp = parent_column->second;
      const int cb = column->second;
      joint << inverse.block<6, 6>(cp, cp), inverse.block<6, 6>(cp, cb),
          inverse.block<6, 6>(cb, cp), inverse.block<6, 6>(cb, cb);
      c = g * joint * g.transpose();
      if (gradient_effect.size() > 0) {
        Eigen::MatrixXd stacked(12, gradient_effect.cols());
        stacked << gradient_effect.middleRows(cp, 6), gradient_effect.middleRows(cb, 6);
        effect = g * stacked;
      }
    }
    const Eigen::Vector3d arm = poses[b].translation() - centres[b];
    Eigen::Matrix<double, 6, 6> to_ros = Eigen::Matrix<double, 6, 6>::Zero();
    to_ros.block<3, 3>(0, 0) = -skew(arm);                   // d origin / d w
    to_ros.block<3, 3>(0, 3) = Eigen::Matrix3d::Identity();  // d origin / d t
    to_ros.block<3, 3>(3, 0) = Eigen::Matrix3d::Identity();  // d rotation / d w
    result->covariances[b] = variance * to_ros * c * to_ros.transpose();
    result->covariance_valid[b] = result->covariances[b].allFinite();
    if (effect.size() > 0) {
      const Eigen::MatrixXd moved = to_ros * effect;
      result->offset_gradient_covariances[b] = moved * moved.transpose();
      result->covariance_valid[b] =
          result->covariance_valid[b] && result->offset_gradient_covariances[b].allFinite();
    }
  }
}

// The image support of a bone at its final pose: its contour samples in every view's map, and
// how many of them lie within `settings.inlier_distance_px` (full-resolution pixels) of an
// image edge, where the outline lies and where the view's edge offset (`offsets_px[v]`,
// full-resolution pixels, along `offset_directions[v]` or, for a fresh contour, offsetDirection)
// puts each sample. The samples are the model points of the last contour extracted per view
// (`model_points[v]`; the final step is small, so the rim is the same), projected at the final
// pose; a view without them has its contour extracted afresh. Samples inside another bone's
// silhouette (`covering[v]`: masks on map v's pixels) are not counted: where one implant crosses
// another their edges fade, so a femoral component over the tray in flexion would lose a fifth of
// its inliers to the overlap alone, and the fraction would follow the motion rather than the fit.
// With two or more views, also the samples the status leaves out as unseen
// (BoneQuality::unseen_points). `residual_correlation`: also measure
// BoneQuality::residual_correlation_samples (for the covariance only; its lag sums are the
// costliest part here).
BoneQuality imageQuality(const imaging::SilhouetteModel& silhouette, const geometry::Pose& pose,
                         const std::vector<imaging::EdgeMap>& maps,
                         const std::vector<std::vector<Eigen::Vector3d>>& model_points,
                         const std::vector<std::vector<Eigen::Vector2d>>& offset_directions,
                         const std::vector<double>& offsets_px,
                         RegistrationSettings::EdgeOffsetModel offset_model,
                         const std::vector<std::vector<const cv::Mat*>>& covering,
                         const QualitySettings& settings, bool residual_correlation) {
  const double inlier_px = settings.inlier_distance_px;
  BoneQuality quality;
  int inliers = 0;
  int offset_inliers = 0;
  double squared = 0.0;
  // Per view, each sample's signed edge distance in contour order (NaN: not an inlier).
  std::vector<std::vector<double>> signed_distances(maps.size());
  // Per view: counted samples, those the status calls inliers, and those with no edge near
  // (only where another view could hold the bone).
  const bool count_unseen = maps.size() > 1 && settings.unseen_edge_distance_px > 0.0;
  std::vector<int> view_points(maps.size(), 0);
  std::vector<int> view_inliers(maps.size(), 0);
  std::vector<int> view_unseen(maps.size(), 0);
  for (std::size_t v = 0; v < maps.size(); ++v) {
    const imaging::EdgeMap& map = maps[v];
    const geometry::XrayCamera& camera = map.camera();
    const geometry::Pose camera_from_mesh = camera.worldFromCamera().inverse() * pose;
    const double offset = v < offsets_px.size() ? offsets_px[v] * map.scale() : 0.0;
    std::vector<Eigen::Vector2d> pixels;
    std::vector<Eigen::Vector2d> shifts;  // map pixels, per sample
    if (v < model_points.size() && !model_points[v].empty()) {
      const bool directed =
          v < offset_directions.size() && offset_directions[v].size() == model_points[v].size();
      for (std::size_t k = 0; k < model_points[v].size(); ++k) {
        Eigen::Vector2d pixel;
        if (!camera.project(camera_from_mesh * model_points[v][k], &pixel)) continue;
        pixels.push_back(pixel);
        shifts.push_back(directed ? Eigen::Vector2d(offset * offset_directions[v][k])
                                  : Eigen::Vector2d::Zero());
      }
    } else {
      for (const auto& c : silhouette.contour(camera, camera_from_mesh, 1.0)) {
        pixels.push_back(c.pixel);
        shifts.push_back(offset * offsetDirection(c, offset_model));
      }
    }
    const auto covered = [&](const Eigen::Vector2d& pixel) {
      if (v >= covering.size()) return false;
      const int u = static_cast<int>(std::lround(pixel.x()));
      const int w = static_cast<int>(std::lround(pixel.y()));
      for (const cv::Mat* mask : covering[v]) {
        if (u >= 0 && w >= 0 && u < mask->cols && w < mask->rows && mask->at<uchar>(w, u) != 0) {
          return true;
        }
      }
      return false;
    };
    // Whether a sample at this position lies within inlier_px of an edge; its edge distance
    // (full-resolution pixels) in `distance`.
    // `on_map`: whether the sample lies on the map at all.
    const auto within = [&](const Eigen::Vector2d& at, double* distance, bool* on_map = nullptr) {
      double du = 0.0;
      double dv = 0.0;
      const bool sampled = map.sample(at.x(), at.y(), distance, &du, &dv);
      if (on_map) *on_map = sampled;
      if (!sampled) return false;
      *distance /= map.scale();
      return std::abs(*distance) <= inlier_px;
    };
    for (std::size_t k = 0; k < pixels.size(); ++k) {
      const Eigen::Vector2d& pixel = pixels[k];
      signed_distances[v].push_back(std::numeric_limits<double>::quiet_NaN());  // a gap unless set
      if (covered(pixel)) {
        ++quality.covered_points;
        continue;
      }
      ++quality.contour_points;
      ++view_points[v];
      double d = 0.0;
      bool on_map = false;
      const bool inlier = within(pixel, &d, &on_map);
      if (inlier) {
        ++inliers;
        squared += d * d;
        signed_distances[v].back() = d;
      }
      // Without an offset (none estimated, or the offset model kNone) the same sample.
      double offset_d = 0.0;
      const bool offset_inlier = shifts[k].isZero() ? inlier : within(pixel + shifts[k], &offset_d);
      if (offset_inlier) ++offset_inliers;
      if (settings.inliers_at_edge_offset ? offset_inlier : inlier) ++view_inliers[v];
      if (count_unseen && on_map && std::abs(d) > settings.unseen_edge_distance_px &&
          map.amidClippedGrey(pixel)) {
        ++view_unseen[v];
      }
    }
  }
  // A view's unseen samples are left out while the other views hold the bone.
  for (std::size_t v = 0; v < maps.size() && count_unseen; ++v) {
    int other_points = 0;
    int other_inliers = 0;
    for (std::size_t w = 0; w < maps.size(); ++w) {
      if (w == v) continue;
      other_points += view_points[w];
      other_inliers += view_inliers[w];
    }
    if (other_points > 0 &&
        other_inliers >= settings.held_by_other_views_inlier_fraction * other_points) {
      quality.unseen_points += view_unseen[v];
    }
  }
  if (residual_correlation) {
    quality.residual_correlation_samples = integratedAutocorrelation(signed_distances);
  }
  if (quality.contour_points > 0) {
    quality.contour_inlier_fraction = static_cast<double>(inliers) / quality.contour_points;
    quality.offset_inlier_fraction = static_cast<double>(offset_inliers) / quality.contour_points;
  }
  if (inliers > 0) {
    quality.contour_rms_px = std::sqrt(squared / inliers);
    quality.contour_spread_px = rmsAboutSequenceMeans(signed_distances);
  }
  return quality;
}

// From a bone's pose covariance (ROS order): the translation's standard deviation along the
// beam of `camera` through the bone's origin, and the largest rotational one.
void addCovarianceQuality(const Eigen::Matrix<double, 6, 6>& covariance, const geometry::Pose& pose,
                          const geometry::XrayCamera& camera, BoneQuality* quality) {
  const Eigen::Vector3d beam =
      (pose.translation() - camera.worldFromCamera().translation()).normalized();
  quality->out_of_plane_sd_m =
      std::sqrt(std::max(0.0, beam.dot(covariance.block<3, 3>(0, 0) * beam)));
  const Eigen::Matrix3d rotation = covariance.block<3, 3>(3, 3);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(
      0.5 * (rotation + rotation.transpose()), Eigen::EigenvaluesOnly);
  quality->max_rotation_sd_rad = std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff()));
}

// Whether reflection `c` of a bone's candidate reflections (mirror_ambiguity.h) needs no solve of
// its own: it lies within `min_difference` (rad) of the bone's own orientation `pose` (a bone
// seen square to the beam is its own reflection) or of an earlier candidate (with a tray's turn
// near zero its tilt reflection is its full mirror: one solve serves).
bool repeatsAReflection(const std::vector<geometry::Pose>& candidates, std::size_t c,
                        const geometry::Pose& pose, double min_difference) {
  const auto near = [&](const geometry::Pose& other) {
    return geometry::rotationAngleBetween(other.linear(), candidates[c].linear()) < min_difference;
  };
  return near(pose) || std::any_of(candidates.begin(), candidates.begin() + c, near);
}

// The setting among `values` whose YAML / command-line name (`name_of`) is `name`; throws
// InputError naming `what` and the known names.
template <typename Setting>
Setting settingFromName(const std::string& name, std::initializer_list<Setting> values,
                        std::string (*name_of)(Setting), const std::string& what) {
  std::string known;
  for (Setting value : values) {
    if (name_of(value) == name) return value;
    known += (known.empty() ? "" : ", ") + name_of(value);
  }
  throw InputError("registration: " + what + " '" + name + "' is not one of " + known);
}

}  // namespace

RegistrationSettings::Parameterisation parameterisationFromName(const std::string& name) {
  using P = RegistrationSettings::Parameterisation;
  return settingFromName(name, {P::kAbsolute, P::kParentRelative}, &parameterisationName,
                         "parameterisation");
}

std::string parameterisationName(RegistrationSettings::Parameterisation parameterisation) {
  return parameterisation == RegistrationSettings::Parameterisation::kParentRelative
             ? "parent_relative"
             : "absolute";
}

RegistrationSettings::TrackingPrediction trackingPredictionFromName(const std::string& name) {
  using P = RegistrationSettings::TrackingPrediction;
  return settingFromName(name, {P::kConstantVelocity, P::kJointCoordinates},
                         &trackingPredictionName, "tracking_prediction");
}

std::string trackingPredictionName(RegistrationSettings::TrackingPrediction prediction) {
  return prediction == RegistrationSettings::TrackingPrediction::kJointCoordinates
             ? "joint_coordinates"
             : "constant_velocity";
}

bool withinMotionLimits(const geometry::Pose& from, const geometry::Pose& to,
                        const RegistrationSettings& settings, int frames) {
  return (to.translation() - from.translation()).norm() <=
             frames * settings.max_translation_from_start_m &&
         geometry::rotationAngleBetween(to.linear(), from.linear()) <=
             frames * settings.max_rotation_from_start_rad;
}

RegistrationSettings::EdgeOffsetModel edgeOffsetModelFromName(const std::string& name) {
  using Model = RegistrationSettings::EdgeOffsetModel;
  return settingFromName(name, {Model::kNone, Model::kUniform}, &edgeOffsetModelName,
                         "edge offset model");
}

std::string edgeOffsetModelName(RegistrationSettings::EdgeOffsetModel model) {
  switch (model) {
    case RegistrationSettings::EdgeOffsetModel::kNone:
      return "none";
    case RegistrationSettings::EdgeOffsetModel::kUniform:
      return "uniform";
  }
  return "unknown";
}

std::vector<RegistrationStage> RegistrationSettings::schedule() const {
  if (!stages.empty()) return stages;
  RegistrationStage stage;
  stage.outer_iterations = outer_iterations;
  stage.solver_iterations = solver_iterations;
  stage.contact_from_outer_iteration = contact_from_outer_iteration;
  return {stage};
}

void RegistrationSettings::validate() const {
  for (const auto* list : {&scales, &tracking_scales}) {
    const std::string name = list == &scales ? "scales" : "tracking_scales";
    if (list->empty()) throw InputError("registration: " + name + " must not be empty");
    for (double s : *list) {
      if (!(s > 0.0 && s <= 1.0)) throw InputError("registration: " + name + " must be in (0, 1]");
    }
  }
  if (outer_iterations < 1 || solver_iterations < 1) {
    throw InputError("registration: outer_iterations and solver_iterations must be >= 1");
  }
  if (threads < 1) throw InputError("registration: threads must be >= 1");
  if (!std::isfinite(robust_scale_final_px)) {
    throw InputError("registration: robust_scale_final_px must be a number (<= 0: off)");
  }
  if (!(contour_spacing_px > 0.0) || !(robust_scale_px > 0.0)) {
    throw InputError("registration: contour_spacing_px and robust_scale_px must be > 0");
  }
  if (!(edge_offset_prior_px >= 0.0)) {
    throw InputError("registration: edge_offset_prior_px must be >= 0");
  }
  if (std::isnan(edge_offset_min_px) ||
      edge_offset_min_px == std::numeric_limits<double>::infinity()) {
    throw InputError("registration: edge_offset_min_px must be a number or -.inf (no floor)");
  }
  if (!(edge_offset_tracking.frame_sd_px > 0.0) || !(edge_offset_tracking.drift_px >= 0.0)) {
    throw InputError("registration: edge_offset_tracking needs frame_sd_px > 0 and drift_px >= 0");
  }
  if (!(rendered_edges.saturation_mm > 0.0) || !std::isfinite(rendered_edges.saturation_mm)) {
    throw InputError("registration: rendered_edges needs a finite saturation_mm > 0");
  }
  if (contact_from_outer_iteration < 0) {
    throw InputError("registration: contact_from_outer_iteration must be >= 0");
  }
  if (!(covariance_offset_gradient_sd_px >= 0.0) ||
      !std::isfinite(covariance_offset_gradient_sd_px)) {
    throw InputError("registration: covariance_offset_gradient_sd_px must be a finite number >= 0");
  }
  for (std::size_t k = 0; k < stages.size(); ++k) {
    const RegistrationStage& stage = stages[k];
    const std::string name = "registration: stages[" + std::to_string(k) + "]";
    if (stage.outer_iterations < 1 || stage.solver_iterations < 1) {
      throw InputError(name + ": outer_iterations and solver_iterations must be >= 1");
    }
    if (stage.contact_from_outer_iteration < 0) {
      throw InputError(name + ": contact_from_outer_iteration must be >= 0");
    }
    for (const auto& [bone, weight] : stage.image_weights) {
      if (!(weight >= 0.0))
        throw InputError(name + ": image weight of '" + bone + "' must be >= 0");
    }
  }
  if (!(mirror_check.cost_tolerance >= 0.0) || !(mirror_check.min_difference_deg >= 0.0) ||
      !(mirror_check.min_neutral_gain >= 0.0) ||
      !(mirror_check.max_difference_deg >= mirror_check.min_difference_deg) ||
      !(mirror_check.tracking_turn_max_difference_deg >= 0.0) ||
      mirror_check.outer_iterations < 1 || mirror_check.solver_iterations < 1 ||
      mirror_check.continued_outer_iterations < 0 || !(mirror_check.abandon_cost_ratio > 0.0) ||
      !(mirror_check.abandon_deviation_excess > 0.0) ||
      !(mirror_check.start_deviation_excess > 0.0) ||
      !std::isfinite(mirror_check.neutral_internal_rotation_per_flexion)) {
    throw InputError(
        "registration: mirror_check needs cost_tolerance >= 0, min_difference_deg >= 0, "
        "min_neutral_gain >= 0, a finite neutral_internal_rotation_per_flexion, "
        "max_difference_deg >= min_difference_deg, tracking_turn_max_difference_deg >= 0, "
        "outer_iterations >= 1, solver_iterations >= 1, continued_outer_iterations >= 0, "
        "abandon_cost_ratio > 0, abandon_deviation_excess > 0 and start_deviation_excess > 0");
  }
  if (!(std::isfinite(inner_edge_margin_px) && inner_edge_margin_px >= 0.0) ||
      !(std::isfinite(tracking_inner_edge_margin_px) && tracking_inner_edge_margin_px >= 0.0)) {
    throw InputError(
        "registration: inner_edge_margin_px and tracking_inner_edge_margin_px must be finite and "
        ">= 0");
  }
  if (!(tracking_retry_inlier_drop >= 0.0 && tracking_retry_inlier_drop <= 1.0) ||
      !(tracking_retry_min_inlier_gain >= 0.0)) {
    throw InputError(
        "registration: tracking_retry_inlier_drop must be in [0, 1] and "
        "tracking_retry_min_inlier_gain >= 0");
  }
  if (!(tracking_shift_search_mm >= 0.0) || !std::isfinite(tracking_shift_search_mm)) {
    throw InputError("registration: tracking_shift_search_mm must be finite and >= 0");
  }
  if (!(featureless_noise_ratio >= 0.0) || !std::isfinite(featureless_noise_ratio)) {
    throw InputError("registration: featureless_noise_ratio must be finite and >= 0");
  }
  if (!(tracking_retry_max_inlier_loss >= 0.0 && tracking_retry_max_inlier_loss <= 1.0)) {
    throw InputError("registration: tracking_retry_max_inlier_loss must be in [0, 1]");
  }
  if (!(reflection_retry.below_inlier_fraction >= 0.0 &&
        reflection_retry.below_inlier_fraction <= 1.0) ||
      !(reflection_retry.min_inlier_gain >= 0.0)) {
    throw InputError(
        "registration: reflection_retry needs below_inlier_fraction in [0, 1] and "
        "min_inlier_gain >= 0");
  }
  for (double shift : depth_retry.shifts_mm) {
    if (!std::isfinite(shift) || shift == 0.0) {
      throw InputError("registration: depth_retry: shifts_mm must be finite and non-zero");
    }
  }
  if (!(rotation_retry.above_contour_spread_px >= 0.0) || !(rotation_retry.step_deg > 0.0) ||
      !(rotation_retry.tracking_spread_rise >= 0.0)) {
    throw InputError(
        "registration: rotation_retry needs above_contour_spread_px >= 0, step_deg > 0 and "
        "tracking_spread_rise >= 0");
  }
  if (!(depth_retry.light_below_inlier_fraction >= 0.0 &&
        depth_retry.light_below_inlier_fraction <= 1.0)) {
    throw InputError("registration: depth_retry: light_below_inlier_fraction must be in [0, 1]");
  }
  if (!(depth_retry.other_views_shift_mm >= 0.0)) {
    throw InputError("registration: depth_retry: other_views_shift_mm must be >= 0");
  }
  edges.validate();
  quality.validate();
}

Registrar::Registrar(std::vector<BoneModel> bones, RegistrationSettings settings,
                     std::vector<JointModel> joints)
    : bones_(std::move(bones)), settings_(std::move(settings)), joints_(std::move(joints)) {
  settings_.validate();
  for (const auto& bone : bones_) {
    if (!bone.silhouette) throw InputError("registration: bone '" + bone.name + "' has no model");
    centroids_.push_back(bone.silhouette->mesh().volumeCentroid());
  }
  const int bone_count = static_cast<int>(bones_.size());
  for (const auto& joint : joints_) {
    if (joint.parent < 0 || joint.parent >= bone_count || joint.child < 0 ||
        joint.child >= bone_count || joint.parent == joint.child) {
      throw InputError("registration: joint '" + joint.name +
                       "' needs two different bones of this registrar");
    }
    if (joint.ligaments.enabled) joint.ligaments.validate();
  }
}

RegistrationResult Registrar::solve(const std::vector<ViewImage>& views,
                                    const std::vector<geometry::Pose>& initial_poses,
                                    const std::vector<bool>& loaded,
                                    const EdgeOffsetPriors& offset_priors,
                                    const std::vector<double>& recent_spreads_px) const {
  RegistrationResult result =
      solveWithRetries(views, initial_poses, loaded, offset_priors, recent_spreads_px);
  // The solutions compared on the way carry the sampled contact figures only (finish).
  for (std::size_t j = 0; j < joints_.size() && j < result.joints.size(); ++j) {
    const JointModel& joint = joints_[j];
    JointResult& joint_result = result.joints[j];
    if (!joint.contact || !joint_result.has_contact) continue;
    joint.contact->addSeparation(result.poses[joint.parent], result.poses[joint.child],
                                 &joint_result.contact);
  }
  return result;
}

RegistrationResult Registrar::solveWithRetries(const std::vector<ViewImage>& views,
                                               const std::vector<geometry::Pose>& initial_poses,
                                               const std::vector<bool>& loaded,
                                               const EdgeOffsetPriors& offset_priors,
                                               const std::vector<double>& recent_spreads_px) const {
  if (!recent_spreads_px.empty() && recent_spreads_px.size() != bones_.size()) {
    throw InputError("registration: recent contour spreads for " +
                     std::to_string(recent_spreads_px.size()) + " bone(s), not " +
                     std::to_string(bones_.size()));
  }
  if (!offset_priors.empty()) {
    bool valid = offset_priors.size() == bones_.size();
    for (const auto& per_view : offset_priors) {
      valid = valid && per_view.size() == views.size();
      for (const EdgeOffsetPrior& prior : per_view) {
        valid = valid && std::isfinite(prior.mean_px) && prior.sigma_px > 0.0;
      }
    }
    if (!valid) {
      throw InputError(
          "registration: edge offset priors need one finite mean and positive sigma per bone "
          "and view");
    }
  }
  std::vector<imaging::EdgeMap> finest_maps;
  std::optional<RegistrationResult> unchecked;
  RegistrationResult result = solveChecked(views, initial_poses, loaded, offset_priors,
                                           settings_.threads, &finest_maps, &unchecked);
  retryReflections(views, initial_poses, loaded, offset_priors, unchecked ? &*unchecked : nullptr,
                   &result);
  retryRotations(views, loaded, offset_priors, recent_spreads_px, &result);
  if (!settings_.depth_retry.enabled) return result;
  // Fewer bones not ok first (lost counts twice), then more contour inliers.
  const auto rank = [&](const RegistrationResult& r) { return resultRank(r, settings_.quality); };
  auto best_rank = rank(result);
  SolveCounts counts(result);
  // Counts a retry's solve and keeps it if it ranks better.
  const auto consider = [&](RegistrationResult& retry) {
    counts.add(retry);
    const auto retry_rank = rank(retry);
    if (retry_rank < best_rank) {
      best_rank = retry_rank;
      result = std::move(retry);
    }
  };
  if (best_rank.first == 0) {
    // Every bone ok: the light retry, if a bone's contour lies short of the edges.
    bool short_of_edges = false;
    for (const BoneQuality& q : result.quality) {
      short_of_edges = short_of_edges || q.contour_inlier_fraction <
                                             settings_.depth_retry.light_below_inlier_fraction;
    }
    if (!short_of_edges || views.size() != 1 || finest_maps.empty()) return result;
    const std::vector<std::vector<geometry::Pose>> light_starts = depthShifted(views, result.poses);
    // Solved from the first solve's maps (a shift along the beam changes the view of the bones
    // little), each thread on maps of its own.
    const bool side_by_side = settings_.threads > 1 && light_starts.size() > 1;
    std::vector<RegistrationResult> light(light_starts.size());
    parallelFor(light_starts.size(), side_by_side ? settings_.threads : 1, [&](std::size_t k) {
      std::vector<imaging::EdgeMap> own_maps;
      if (side_by_side) own_maps = unsharedMaps(finest_maps);
      light[k] = solveFrom(views, light_starts[k], loaded, offset_priors,
                           side_by_side ? &own_maps : &finest_maps);
    });
    for (RegistrationResult& retry : light) consider(retry);
    counts.writeTo(&result);
    return result;
  }
  // From the result, whose in-plane position and rotations are mostly right, rather than from
  // the start (measured on the crude protocol: 91 against 89 % success); from the first result
  // even where the other views' shift below leaves fewer bones in doubt but not none.
  const std::vector<std::vector<geometry::Pose>> retry_starts = depthShifted(views, result.poses);
  if (views.size() > 1 && settings_.depth_retry.other_views_shift_mm > 0.0) {
    // Kept only if it leaves fewer bones in doubt: a shift to the wrong edges, with a few more
    // inliers than the result at the same doubt, would only start the fixed shifts elsewhere.
    std::optional<RegistrationResult> moved =
        solvedFromOtherViewsShifts(views, loaded, offset_priors, result);
    if (moved) {
      counts.add(*moved);
      const auto moved_rank = rank(*moved);
      if (moved_rank.first < best_rank.first) {
        best_rank = moved_rank;
        result = std::move(*moved);
      }
    }
    if (best_rank.first == 0) {
      counts.writeTo(&result);
      return result;
    }
  }
  // One thread solves a shift only if those before it left a bone in doubt; more threads solve
  // them all at once and leave unused (and uncounted) the ones after the first that clears it.
  // A speculative solve that throws is left to the loop below, which throws only if it gets
  // that far, as one thread would.
  std::vector<std::optional<RegistrationResult>> retries(retry_starts.size());
  if (settings_.threads > 1) {
    parallelFor(retry_starts.size(), settings_.threads, [&](std::size_t k) {
      try {
        retries[k] = solveChecked(views, retry_starts[k], loaded, offset_priors, 1);
      } catch (const std::exception&) {
      }
    });
  }
  for (std::size_t k = 0; k < retry_starts.size(); ++k) {
    if (!retries[k]) {
      retries[k] = solveChecked(views, retry_starts[k], loaded, offset_priors, settings_.threads);
    }
    consider(*retries[k]);
    if (best_rank.first == 0) break;
  }
  counts.writeTo(&result);
  return result;
}

std::optional<RegistrationResult> Registrar::solvedFromOtherViewsShifts(
    const std::vector<ViewImage>& views, const std::vector<bool>& loaded,
    const EdgeOffsetPriors& offset_priors, const RegistrationResult& result) const {
  const std::vector<std::string> status =
      classifyBones(result, everySampleCounted(settings_.quality));
  std::vector<geometry::Pose> starts = result.poses;
  bool moved = false;
  for (std::size_t b = 0; b < bones_.size() && b < status.size(); ++b) {
    if (status[b] == "ok") continue;
    const auto shifted = posesShiftedToEdges({bones_[b]}, {result.poses[b]}, views, settings_.edges,
                                             1e-3 * settings_.depth_retry.other_views_shift_mm);
    if (!shifted) continue;
    starts[b] = shifted->front();
    moved = true;
  }
  if (!moved) return std::nullopt;
  try {
    return solveChecked(views, starts, loaded, offset_priors, settings_.threads);
  } catch (const InputError&) {
    return std::nullopt;  // a start outside a view
  }
}

std::vector<std::vector<geometry::Pose>> Registrar::depthShifted(
    const std::vector<ViewImage>& views, const std::vector<geometry::Pose>& poses) const {
  const geometry::Pose camera_from_fixed = views.front().camera.worldFromCamera().inverse();
  std::vector<std::vector<geometry::Pose>> shifted;
  for (double shift_mm : settings_.depth_retry.shifts_mm) {
    std::vector<geometry::Pose> starts = poses;
    for (std::size_t b = 0; b < starts.size(); ++b) {
      geometry::Pose in_camera = camera_from_fixed * starts[b];
      const Eigen::Vector3d centre = in_camera * centroids_[b];
      if (!(centre.norm() > 0.0)) continue;
      in_camera.translation() += 1e-3 * shift_mm * centre.normalized();
      starts[b] = camera_from_fixed.inverse() * in_camera;
    }
    shifted.push_back(std::move(starts));
  }
  return shifted;
}

void Registrar::retryReflections(const std::vector<ViewImage>& views,
                                 const std::vector<geometry::Pose>& initial_poses,
                                 const std::vector<bool>& loaded,
                                 const EdgeOffsetPriors& offset_priors,
                                 const RegistrationResult* unchecked,
                                 RegistrationResult* result) const {
  const ReflectionRetrySettings& retry_settings = settings_.reflection_retry;
  // A second view sees the reflection from another side.
  if (!retry_settings.enabled || views.size() != 1 ||
      result->quality.size() != result->poses.size()) {
    return;
  }
  const geometry::Pose camera_from_fixed = views.front().camera.worldFromCamera().inverse();
  const double min_difference = geometry::degToRad(settings_.mirror_check.min_difference_deg);
  SolveCounts counts(*result);
  if (!retry_settings.before_mirror_check || unchecked == nullptr ||
      unchecked->quality.size() != unchecked->poses.size()) {
    unchecked = nullptr;
  }
  const auto below_gate = [&](const RegistrationResult& r, std::size_t b) {
    return r.quality[b].contour_inlier_fraction < retry_settings.below_inlier_fraction;
  };
  for (std::size_t b = 0; b < result->poses.size(); ++b) {
    // The reflections of the bone in the result, or in the first solution if only that one
    // left it below the gate (ReflectionRetrySettings::before_mirror_check).
    const RegistrationResult* source = result;
    if (!below_gate(*result, b)) {
      if (unchecked == nullptr || mirrorChecked(b) || unchecked->diverged[b] ||
          !below_gate(*unchecked, b)) {
        continue;
      }
      source = unchecked;
    }
    const double inliers = source->quality[b].contour_inlier_fraction;
    const geometry::Pose pose = camera_from_fixed * source->poses[b];
    const std::vector<geometry::Pose> candidates = {
        mirroredAcrossBeam(pose), turnReflectedAcrossBeam(pose), tiltReflectedAcrossBeam(pose)};
    const int first_trouble = resultRank(*result, settings_.quality).first;
    const double required_inliers = inliers + retry_settings.min_inlier_gain;
    // Of the candidates that fit better, the one that ends nearest the start: a tray's tilt
    // reflection and its turn reflection can fit a real frame about equally well, 30 deg apart
    // (Kneel frame 0160), and the start is the only other evidence an image-only solve has.
    std::optional<RegistrationResult> best;
    double best_distance = std::numeric_limits<double>::infinity();
    // Each candidate is solved from the same result, so threads may share them out.
    std::vector<std::size_t> solved;
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      if (!repeatsAReflection(candidates, c, pose, min_difference)) solved.push_back(c);
    }
    std::vector<RegistrationResult> retries(solved.size());
    parallelFor(solved.size(), settings_.threads, [&](std::size_t k) {
      std::vector<geometry::Pose> starts = source->poses;
      starts[b] = camera_from_fixed.inverse() * candidates[solved[k]];
      retries[k] = solveChecked(views, starts, loaded, offset_priors,
                                solved.size() > 1 ? 1 : settings_.threads);
    });
    for (RegistrationResult& retry : retries) {
      counts.add(retry);
      if (retry.diverged[b] || !(retry.quality[b].contour_inlier_fraction > required_inliers) ||
          !(retry.final_cost < result->final_cost) ||
          resultRank(retry, settings_.quality).first > first_trouble) {
        continue;
      }
      const double distance =
          geometry::rotationAngleBetween(retry.poses[b].linear(), initial_poses[b].linear());
      if (distance < best_distance) {
        best_distance = distance;
        best = std::move(retry);
      }
    }
    if (best) {
      *result = std::move(*best);
      unchecked = nullptr;  // later bones start from the better result
    }
  }
  counts.writeTo(result);
}

void Registrar::retryRotations(const std::vector<ViewImage>& views, const std::vector<bool>& loaded,
                               const EdgeOffsetPriors& offset_priors,
                               const std::vector<double>& recent_spreads_px,
                               RegistrationResult* result) const {
  const RotationRetrySettings& retry_settings = settings_.rotation_retry;
  if (!retry_settings.enabled || result->quality.size() != result->poses.size()) return;
  const double step = geometry::degToRad(retry_settings.step_deg);
  const std::array<Eigen::Matrix3d, 6> turns = {
      geometry::rotationX(step),  geometry::rotationX(-step), geometry::rotationY(step),
      geometry::rotationY(-step), geometry::rotationZ(step),  geometry::rotationZ(-step)};
  const bool tracked = !recent_spreads_px.empty();
  const auto threshold = [&](std::size_t b) {
    if (!tracked) return retry_settings.above_contour_spread_px;
    if (!std::isfinite(recent_spreads_px[b]) || !(retry_settings.tracking_spread_rise > 0.0)) {
      return std::numeric_limits<double>::infinity();
    }
    return std::max(retry_settings.above_contour_spread_px,
                    retry_settings.tracking_spread_rise * recent_spreads_px[b]);
  };
  std::vector<std::vector<geometry::Pose>> starts;
  std::vector<std::size_t> turned_bone;  // per start
  for (std::size_t b = 0; b < result->poses.size(); ++b) {
    if (result->diverged[b] || !(result->quality[b].contour_spread_px > threshold(b))) continue;
    for (const Eigen::Matrix3d& turn : turns) {
      std::vector<geometry::Pose> turned = result->poses;
      turned[b].linear() = result->poses[b].linear() * turn;
      starts.push_back(std::move(turned));
      turned_bone.push_back(b);
    }
  }
  if (starts.empty()) return;
  // Each solve starts from the same result, so threads may share them out.
  std::vector<RegistrationResult> retries(starts.size());
  parallelFor(starts.size(), settings_.threads, [&](std::size_t k) {
    retries[k] = solveChecked(views, starts[k], loaded, offset_priors, 1);
  });
  SolveCounts counts(*result);
  const int first_trouble = resultRank(*result, settings_.quality).first;
  std::optional<std::size_t> best;
  double best_cost = result->final_cost;
  for (std::size_t k = 0; k < retries.size(); ++k) {
    const RegistrationResult& retry = retries[k];
    counts.add(retry);
    const bool diverged =
        std::find(retry.diverged.begin(), retry.diverged.end(), true) != retry.diverged.end();
    if (diverged || resultRank(retry, settings_.quality).first > first_trouble) continue;
    // A tracked frame's retry must also undo at least half the rise that called it: on noisy
    // frames a turned start often ends at a lower cost with the spread about as wide, another
    // guess rather than a better fit.
    const std::size_t b = turned_bone[k];
    if (tracked && !(retry.quality[b].contour_spread_px <=
                     0.5 * (result->quality[b].contour_spread_px + recent_spreads_px[b]))) {
      continue;
    }
    if (retry.final_cost < best_cost) {
      best_cost = retry.final_cost;
      best = k;
    }
  }
  if (best) *result = std::move(retries[*best]);
  counts.writeTo(result);
}

bool Registrar::mirrorChecked(std::size_t b) const {
  for (const JointModel& joint : joints_) {
    if (joint.type == kinematics::JointType::kKnee && joint.child == static_cast<int>(b)) {
      return true;
    }
  }
  return false;
}

RegistrationResult Registrar::solveChecked(const std::vector<ViewImage>& views,
                                           const std::vector<geometry::Pose>& initial_poses,
                                           const std::vector<bool>& loaded,
                                           const EdgeOffsetPriors& offset_priors, int threads,
                                           std::vector<imaging::EdgeMap>* finest_maps_out,
                                           std::optional<RegistrationResult>* unchecked_out) const {
  std::vector<imaging::EdgeMap> finest_maps;
  RegistrationResult result = solveFrom(views, initial_poses, loaded, offset_priors, &finest_maps);
  if (finest_maps_out != nullptr) *finest_maps_out = finest_maps;
  // A second view sees the mirror from another side: only single views are ambiguous.
  if (!settings_.mirror_check.enabled || views.size() != 1) return result;
  const geometry::Pose camera_from_fixed = views.front().camera.worldFromCamera().inverse();
  for (const JointModel& joint : joints_) {
    if (result.diverged[joint.parent] || result.diverged[joint.child]) continue;
    // Its rule (nearer neutral wins) and its bounds are the knee's.
    if (joint.type != kinematics::JointType::kKnee) continue;
    const auto deviation = [&](const std::vector<geometry::Pose>& poses) {
      return neutralDeviation(joint.ligaments,
                              joint.coordinates(poses[joint.parent], poses[joint.child]),
                              settings_.mirror_check.neutral_internal_rotation_per_flexion);
    };
    const geometry::Pose child = camera_from_fixed * result.poses[joint.child];
    std::vector<geometry::Pose> candidates;
    if (settings_.mirror_check.mirror_reflection) candidates.push_back(mirroredAcrossBeam(child));
    if (settings_.mirror_check.turn_reflection)
      candidates.push_back(turnReflectedAcrossBeam(child));
    if (settings_.mirror_check.tilt_reflection)
      candidates.push_back(tiltReflectedAcrossBeam(child));
    const double min_difference = geometry::degToRad(settings_.mirror_check.min_difference_deg);
    const double first_cost = result.final_cost;
    // A candidate must be nearer neutral than the solution by the margin; of those, the nearest.
    const double required_deviation =
        deviation(result.poses) - settings_.mirror_check.min_neutral_gain;
    // No pose is nearer neutral than zero: a solution within the margin of neutral keeps.
    if (!(required_deviation > 0.0)) continue;
    double best_deviation = std::numeric_limits<double>::infinity();
    SolveCounts counts(result);
    // The candidates worth a solve: each start is the solution with the child reflected.
    std::vector<std::vector<geometry::Pose>> candidate_starts;
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      const geometry::Pose& candidate = candidates[c];
      if (geometry::rotationAngleBetween(candidate.linear(), child.linear()) >
              geometry::degToRad(settings_.mirror_check.max_difference_deg) ||
          repeatsAReflection(candidates, c, child, min_difference)) {
        continue;
      }
      std::vector<geometry::Pose> starts = result.poses;
      starts[joint.child] = camera_from_fixed.inverse() * candidate;
      if (deviation(starts) > required_deviation + settings_.mirror_check.start_deviation_excess) {
        continue;
      }
      candidate_starts.push_back(std::move(starts));
    }
    const CandidateGate gate{settings_.mirror_check.abandon_cost_ratio * first_cost, deviation,
                             required_deviation + settings_.mirror_check.abandon_deviation_excess,
                             required_deviation, settings_.mirror_check.continued_outer_iterations};
    // Each candidate is solved from the same solution and judged on its own, so threads may
    // share them out; a thread then works on maps of its own (EdgeMap::unshared). The mirror
    // differs from the solution in rotation only: the finest scale's maps serve.
    const bool side_by_side = threads > 1 && candidate_starts.size() > 1;
    std::vector<Solution> solved(candidate_starts.size());
    parallelFor(candidate_starts.size(), side_by_side ? threads : 1, [&](std::size_t k) {
      std::vector<imaging::EdgeMap> own_maps;
      if (side_by_side) own_maps = unsharedMaps(finest_maps);
      solved[k] = solveUnfinished(views, candidate_starts[k], loaded, offset_priors,
                                  side_by_side ? &own_maps : &finest_maps, &gate);
    });
    // The candidates' joint figures and image quality are worked out for the one kept only.
    Solution best;
    bool replaced = false;
    for (Solution& candidate_solution : solved) {
      const RegistrationResult& mirror = candidate_solution.result;
      counts.add(mirror);
      if (candidate_solution.abandoned) continue;
      if (mirror.diverged[joint.parent] || mirror.diverged[joint.child] ||
          mirror.final_cost > (1.0 + settings_.mirror_check.cost_tolerance) * first_cost) {
        continue;
      }
      const double mirror_deviation = deviation(mirror.poses);
      if (mirror_deviation < required_deviation && mirror_deviation < best_deviation) {
        best_deviation = mirror_deviation;
        best = std::move(candidate_solution);
        replaced = true;
      }
    }
    if (replaced) {
      if (unchecked_out != nullptr && !*unchecked_out) *unchecked_out = result;
      finish(views, &best);
      result = std::move(best.result);
    }
    counts.writeTo(&result);
  }
  return result;
}

RegistrationResult Registrar::solveFrom(const std::vector<ViewImage>& views,
                                        const std::vector<geometry::Pose>& initial_poses,
                                        const std::vector<bool>& loaded,
                                        const EdgeOffsetPriors& offset_priors,
                                        std::vector<imaging::EdgeMap>* finest_maps) const {
  const bool reuse_maps = finest_maps != nullptr && !finest_maps->empty();
  Solution solution = solveUnfinished(views, initial_poses, loaded, offset_priors, finest_maps);
  finish(views, &solution);
  if (finest_maps != nullptr && !reuse_maps) *finest_maps = std::move(solution.maps);
  return std::move(solution.result);
}

Registrar::Solution Registrar::solveUnfinished(const std::vector<ViewImage>& views,
                                               const std::vector<geometry::Pose>& initial_poses,
                                               const std::vector<bool>& loaded,
                                               const EdgeOffsetPriors& offset_priors,
                                               const std::vector<imaging::EdgeMap>* finest_maps,
                                               const CandidateGate* gate) const {
  if (views.empty()) throw InputError("registration: no views");
  if (initial_poses.size() != bones_.size()) {
    throw InputError("registration: " + std::to_string(initial_poses.size()) + " pose(s) for " +
                     std::to_string(bones_.size()) + " bone(s)");
  }
  for (std::size_t b = 0; b < bones_.size(); ++b) {
    if (!geometry::isValidPose(initial_poses[b])) {
      throw InputError("registration: the starting pose of bone '" + bones_[b].name +
                       "' is not a finite rigid transform");
    }
  }

  RegistrationResult result;
  result.poses = initial_poses;
  result.contour_points.assign(bones_.size(), 0);
  // Per bone and view, the model points of the contour last extracted at the finest scale.
  std::vector<std::vector<std::vector<Eigen::Vector3d>>> finest_model_points(
      bones_.size(), std::vector<std::vector<Eigen::Vector3d>>(views.size()));
  // ... and which way the edge offset moved each of them.
  std::vector<std::vector<std::vector<Eigen::Vector2d>>> finest_offset_directions(
      bones_.size(), std::vector<std::vector<Eigen::Vector2d>>(views.size()));
  result.diverged.assign(bones_.size(), false);
  // Edge offsets at the current scale's pixels, per bone and view; carried across outer
  // iterations and scales (converted), as they describe the image, not the step.
  std::vector<std::vector<double>> offsets(bones_.size(), std::vector<double>(views.size(), 0.0));
  double previous_scale = settings_.scales.front();
  std::vector<cv::Rect> rois;
  for (const auto& view : views) {
    rois.push_back(regionOfInterest(view.camera, bones_, initial_poses, settings_.roi_margin_px));
  }

  const std::vector<RegistrationStage> schedule = settings_.schedule();
  const bool reuse_maps = finest_maps != nullptr && !finest_maps->empty();
  if (reuse_maps) previous_scale = settings_.scales.back();
  const bool with_offsets =
      settings_.edge_offset_model != RegistrationSettings::EdgeOffsetModel::kNone;
  const auto prior_of = [&](std::size_t b, std::size_t v) {
    EdgeOffsetPrior prior;
    prior.sigma_px = settings_.edge_offset_prior_px;
    return offset_priors.empty() ? prior : offset_priors[b][v];
  };
  if (with_offsets) {
    for (std::size_t b = 0; b < bones_.size(); ++b) {
      for (std::size_t v = 0; v < views.size(); ++v) {
        offsets[b][v] = prior_of(b, v).mean_px * previous_scale;
      }
    }
  }
  std::vector<imaging::EdgeMap> maps;  // of the current scale; the finest one at the end
  bool continued = false;              // a candidate's extra outer iterations (CandidateGate)
  // The finer scales' maps are built on another core while the first is solved.
  std::optional<EdgeMapPrefetch> prefetch;
  if (!reuse_maps) {
    prefetch.emplace(views, settings_.edges, rois, settings_.scales, settings_.threads > 1);
  }
  for (std::size_t scale_index = reuse_maps ? settings_.scales.size() - 1 : 0;
       scale_index < settings_.scales.size(); ++scale_index) {
    const double scale = settings_.scales[scale_index];
    const bool finest = scale_index + 1 == settings_.scales.size();
    if (reuse_maps) {
      maps = *finest_maps;
    } else {
      maps = prefetch->take(scale_index);
    }
    // Offsets are in pixels of the map's scale.
    for (auto& per_view : offsets) {
      for (double& o : per_view) o *= scale / previous_scale;
    }
    previous_scale = scale;

    for (std::size_t stage_index = 0; stage_index < (finest ? schedule.size() : 1); ++stage_index) {
      const RegistrationStage& stage = schedule[stage_index];
      // A mirror check's solve starts converged but for the mirrored rotation.
      int outer_iterations =
          reuse_maps ? std::min(stage.outer_iterations, settings_.mirror_check.outer_iterations)
                     : stage.outer_iterations;
      if (!finest && settings_.coarse_outer_iterations > 0) {
        outer_iterations = settings_.coarse_outer_iterations;
      }
      // The offsets' floor (edge_offset_min_px) joins one outer iteration after the offsets are
      // freed (edge_offset_hold), at the finest scale.
      const int floor_outer = settings_.edge_offset_hold ? 2 : 1;
      const auto floor_joined = [&](int outer) {
        return finest && outer >= floor_outer && std::isfinite(settings_.edge_offset_min_px);
      };
      for (int outer = 0; outer < outer_iterations; ++outer) {
        ++result.outer_iterations;
        const double robust_scale =
            scale * (finest && outer >= 1 && settings_.robust_scale_final_px > 0.0
                         ? settings_.robust_scale_final_px
                         : settings_.robust_scale_px);
        std::vector<std::array<double, 6>> increments(bones_.size(), std::array<double, 6>{});
        std::vector<Eigen::Vector3d> centres(bones_.size());
        ceres::Problem::Options problem_options;
        problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
        // Maps without the edges deep inside a bone's own silhouette (inner_edge_margin_px):
        // declared before the problem, whose costs point at them.
        std::deque<imaging::EdgeMap> inner_edge_maps;
        // The contour terms, for the covariance's offset-gradient allowance (last solve only).
        std::vector<OffsetGradientTerm> gradient_terms;
        ceres::Problem problem(problem_options);
        for (std::size_t b = 0; b < bones_.size(); ++b) {
          if (!result.diverged[b]) centres[b] = result.poses[b] * centroids_[b];
        }
        const std::vector<int> relative_parent = relativeParents(result.diverged);
        // Adds a cost over these blocks (`block_bones`: the bone whose increment each block is,
        // or -1), a parent-relative bone's block taken relative to its parent.
        // Residuals the image terms' compression (CompressedResidualsCost) took out of Ceres'
        // count, for the covariance's residual variance.
        int compressed_away = 0;
        const auto add_block = [&](ceres::CostFunction* cost, std::vector<double*> blocks,
                                   std::vector<int> block_bones, bool compress = false) {
          for (std::size_t k = 0; k < block_bones.size(); ++k) {
            const int b = block_bones[k];
            if (b < 0 || relative_parent[b] < 0) continue;
            const int p = relative_parent[b];
            const auto found = std::find(blocks.begin(), blocks.end(), increments[p].data());
            const int parent_block =
                found == blocks.end() ? -1 : static_cast<int>(found - blocks.begin());
            cost = new ParentRelativeCost(cost, static_cast<int>(k), parent_block, centres[p],
                                          centres[b]);
            if (parent_block < 0) {
              blocks.push_back(increments[p].data());
              block_bones.push_back(p);
            }
          }
          if (compress) {
            auto* compressed = new CompressedResidualsCost(cost);
            compressed_away += compressed->represented() - compressed->num_residuals();
            cost = compressed;
          }
          problem.AddResidualBlock(cost, nullptr, blocks);
        };
        for (std::size_t b = 0; b < bones_.size(); ++b) {
          if (result.diverged[b]) continue;
          const geometry::Pose& pose = result.poses[b];
          const double image_weight = bones_[b].image_weight * stage.imageWeight(bones_[b].name);
          int points_in_views = 0;
          for (std::size_t v = 0; v < views.size(); ++v) {
            const geometry::XrayCamera& camera = maps[v].camera();
            const geometry::Pose camera_from_fixed = camera.worldFromCamera().inverse();
            imaging::SilhouetteCrop silhouette;
            auto contour = bones_[b].silhouette->contour(camera, camera_from_fixed * pose,
                                                         settings_.contour_spacing_px, &silhouette);
            // Where a clipped display hides the outline's edge or moves it, the image says
            // nothing about the sample (EdgeMapSettings::clipped_grey_margin): left out of the
            // terms and of the contour the quality figures count.
            contour.erase(std::remove_if(contour.begin(), contour.end(),
                                         [&](const imaging::ContourPoint& c) {
                                           return maps[v].besideClippedGrey(c.pixel, c.normal);
                                         }),
                          contour.end());
            if (finest) {
              auto& kept = finest_model_points[b][v];
              auto& directions = finest_offset_directions[b][v];
              kept.clear();
              directions.clear();
              for (const auto& c : contour) {
                kept.push_back(c.model_point);
                directions.push_back(offsetDirection(c, settings_.edge_offset_model));
              }
            }
            if (contour.empty()) continue;
            std::vector<Eigen::Vector3d> points;
            std::vector<Eigen::Vector2d> offset_directions;
            points.reserve(contour.size());
            offset_directions.reserve(contour.size());
            // Corners are compared where the edge map's smoothing puts their edges once the
            // contour is within a pixel, as the edge offset is (corner_rounding); with
            // rendered_edges, every sample where the edge map finds the bone's rendered edge.
            const bool predict_edges = finest && (!settings_.edge_offset_hold || outer >= 1);
            const bool render_edges = settings_.rendered_edges.enabled && predict_edges;
            const bool round_corners = settings_.corner_rounding && predict_edges && !render_edges;
            // The bone's own inner edges left out once its contour is within a pixel or two
            // (see RegistrationSettings::inner_edge_margin_px).
            const imaging::EdgeMap* map = &maps[v];
            if (settings_.inner_edge_margin_px > 0.0 && predict_edges) {
              const int margin = std::max(
                  1, static_cast<int>(std::lround(settings_.inner_edge_margin_px * scale)));
              cv::Mat inside;
              cv::erode(silhouette.mask, inside,
                        cv::getStructuringElement(cv::MORPH_ELLIPSE,
                                                  cv::Size(2 * margin + 1, 2 * margin + 1)));
              inner_edge_maps.push_back(maps[v].withoutEdgesIn(inside, silhouette.origin));
              map = &inner_edge_maps.back();
            }
            const std::vector<double> rounding =
                render_edges
                    ? renderedEdgeRounding(*bones_[b].silhouette, camera, camera_from_fixed * pose,
                                           contour, settings_.edges,
                                           settings_.rendered_edges.saturation_mm)
                    : cornerRounding(contour, round_corners ? settings_.edges.blur_sigma_px : 0.0);
            std::vector<Eigen::Vector2d> shifts;
            for (std::size_t k = 0; k < contour.size(); ++k) {
              const auto& c = contour[k];
              points.push_back(pose * c.model_point);
              offset_directions.push_back(offsetDirection(c, settings_.edge_offset_model));
              if (round_corners || render_edges) shifts.push_back(-rounding[k] * c.normal);
            }
            points_in_views += static_cast<int>(points.size());
            const std::size_t forward_count = points.size();
            double* offset = &offsets[b][v];
            const int bone = static_cast<int>(b);
            auto* contour_cost =
                new ContourDistanceCost(map, std::move(points), std::move(offset_directions),
                                        centres[b], robust_scale, image_weight, std::move(shifts));
            if (settings_.compute_covariance && finest) {
              gradient_terms.push_back(OffsetGradientTerm{b, contour_cost, increments[b].data(),
                                                          offset, offsetGradientPattern(contour)});
            }
            add_block(contour_cost, {increments[b].data(), offset}, {bone, -1}, true);
            // The offset is a fraction of a pixel: held, it is free only once the contour is
            // that close (see edge_offset_hold).
            const EdgeOffsetPrior prior = prior_of(b, v);
            const bool offset_free = with_offsets && prior.sigma_px > 0.0 &&
                                     (!settings_.edge_offset_hold || (finest && outer >= 1));
            if (offset_free) {
              problem.AddResidualBlock(
                  new EdgeOffsetPriorCost(prior.mean_px * scale, 1.0 / (prior.sigma_px * scale)),
                  nullptr, offset);
              if (floor_joined(outer)) {
                problem.AddResidualBlock(
                    new EdgeOffsetFloorCost(settings_.edge_offset_min_px * scale,
                                            1.0 / (kEdgeOffsetFloorSigmaPx * scale)),
                    nullptr, offset);
              }
            } else {
              problem.SetParameterBlockConstant(offset);
            }
            if (settings_.reverse_term_weight > 0.0) {
              auto pairs = edgeContourPairs(*map, contour, pose, settings_.reverse_band_px * scale,
                                            forward_count, settings_.edge_offset_model, rounding);
              if (!pairs.empty()) {
                add_block(new EdgeToContourCost(camera, std::move(pairs), centres[b], robust_scale,
                                                settings_.reverse_term_weight * image_weight),
                          {increments[b].data(), offset}, {bone, -1}, true);
              }
            }
          }
          result.contour_points[b] = points_in_views;
        }
        // Contact joins once the image has placed the bones: from a crude start, penetration
        // relieved first is relieved along the beam, where the image resists least.
        const bool with_contact =
            stage.contact && finest && outer >= stage.contact_from_outer_iteration;
        for (const auto& joint : joints_) {
          if (result.diverged[joint.parent] || result.diverged[joint.child]) continue;
          double* parent_increment = increments[joint.parent].data();
          double* child_increment = increments[joint.child].data();
          if (!problem.HasParameterBlock(parent_increment) ||
              !problem.HasParameterBlock(child_increment)) {
            continue;
          }
          const geometry::Pose& parent_pose = result.poses[joint.parent];
          const geometry::Pose& child_pose = result.poses[joint.child];
          const std::vector<int> joint_bones = {joint.parent, joint.child};
          if (joint.contact && with_contact) {
            add_block(new ContactCost(joint.contact.get(), parent_pose, centres[joint.parent],
                                      child_pose, centres[joint.child]),
                      {parent_increment, child_increment}, joint_bones);
          }
          const std::size_t j = static_cast<std::size_t>(&joint - joints_.data());
          if (joint.loaded_contact && with_contact && j < loaded.size() && loaded[j]) {
            add_block(new ContactCost(joint.loaded_contact.get(), parent_pose,
                                      centres[joint.parent], child_pose, centres[joint.child]),
                      {parent_increment, child_increment}, joint_bones);
          }
          if (joint.ligaments.enabled && stage.ligaments) {
            add_block(joint.type == kinematics::JointType::kGlenohumeral
                          ? makeGlenohumeralLigamentCost(
                                joint.ligaments, joint.side, parent_pose * joint.parent_anatomical,
                                centres[joint.parent], child_pose * joint.child_anatomical,
                                centres[joint.child])
                          : makeKneeLigamentCost(
                                joint.ligaments, joint.side, parent_pose * joint.parentKneeFrame(),
                                centres[joint.parent], child_pose * joint.childKneeFrame(),
                                centres[joint.child]),
                      {parent_increment, child_increment}, joint_bones);
            if (ceres::CostFunction* bundles = makeLigamentBundleCost(
                    joint.ligaments.bundles, parent_pose, centres[joint.parent], child_pose,
                    centres[joint.child])) {
              add_block(bundles, {parent_increment, child_increment}, joint_bones);
            }
          }
        }
        if (problem.NumResidualBlocks() == 0) break;

        ceres::Solver::Options options;
        options.minimizer_type = ceres::TRUST_REGION;
        options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
        // A handful of unknowns against thousands of residuals: the 6n x 6n normal equations.
        // Each bone's image rows touch its own 7 columns only, so forming them block by block
        // (sparse) halves the dense product's work: on 25 contact + ligament registrations
        // 12.8 -> 11.5 G instructions, the same results (benchmark). Dense where Ceres was
        // built without a sparse library.
        options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
        if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)) {
          options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
          options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
        } else if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)) {
          options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
          options.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
        }
        options.max_num_iterations =
            reuse_maps ? std::min(stage.solver_iterations, settings_.mirror_check.solver_iterations)
                       : stage.solver_iterations;
        options.num_threads = 1;
        options.logging_type = ceres::SILENT;
        ceres::Solver::Summary summary;
        ceres::Solve(options, &problem, &summary);
        result.cost_evaluations += summary.num_residual_evaluations;
        result.solver_iterations += static_cast<int>(summary.iterations.size());
        result.final_cost = summary.final_cost;
        const std::vector<geometry::Pose> linearised = result.poses;  // the increments' origin

        double max_translation = 0.0;
        double max_rotation = 0.0;
        for (std::size_t b = 0; b < bones_.size(); ++b) {
          if (!problem.HasParameterBlock(increments[b].data())) continue;
          std::array<double, 6> inc = increments[b];
          // A relative child moves with its parent, unless the parent's step was just rejected
          // (it is kept where it was; the child then takes its own step alone).
          const int p = relative_parent[b];
          if (p >= 0 && !result.diverged[p]) {
            composeRelativeIncrement(increments[p].data(), increments[b].data(), centres[p],
                                     centres[b], inc.data());
          }
          const geometry::Pose moved = applyIncrement(result.poses[b], centres[b], inc.data());
          if (!withinMotionLimits(initial_poses[b], moved, settings_) ||
              !isViewable(bones_[b], moved, views)) {
            result.diverged[b] = true;
            continue;
          }
          result.poses[b] = moved;
          max_rotation = std::max(max_rotation, Eigen::Vector3d(inc[0], inc[1], inc[2]).norm());
          max_translation =
              std::max(max_translation, Eigen::Vector3d(inc[3], inc[4], inc[5]).norm());
        }
        const bool converged = max_translation < settings_.converged_translation_m &&
                               max_rotation < settings_.converged_rotation_rad;
        if (gate != nullptr && !continued && !converged && finest &&
            stage_index + 1 == schedule.size() && outer + 1 == outer_iterations &&
            summary.final_cost <= gate->max_cost &&
            gate->deviation(result.poses) < gate->keep_deviation) {
          outer_iterations += gate->extra_outer_iterations;
          continued = true;
        }
        // The covariance of the registration's last solve only: each costs a Jacobian evaluation.
        const bool last_solve = finest && stage_index + 1 == schedule.size() &&
                                (converged || outer + 1 == outer_iterations);
        if (settings_.compute_covariance && last_solve) {
          estimateCovariances(&problem, summary, compressed_away, increments, centres, linearised,
                              relative_parent, gradient_terms,
                              settings_.covariance_offset_gradient_sd_px * scale, &result);
        }
        if (converged) {
          // Converged before the offsets' floor joined, with an offset below it: one outer
          // iteration with the floor, so that no solve ends on an offset it forbids.
          bool below_floor = false;
          for (const auto& per_view : offsets) {
            for (double o : per_view) {
              below_floor = below_floor || o < settings_.edge_offset_min_px * scale - 1e-9;
            }
          }
          if (with_offsets && finest && below_floor && outer < floor_outer &&
              floor_outer < outer_iterations) {
            outer = floor_outer - 1;
            continue;
          }
          break;
        }
        if (gate != nullptr && !last_solve &&
            (summary.final_cost > gate->max_cost ||
             gate->deviation(result.poses) > gate->max_deviation)) {
          Solution abandoned{std::move(result), {}, {}, {}, true};
          return abandoned;
        }
      }
    }
  }
  result.edge_offsets_px = offsets;
  for (auto& per_view : result.edge_offsets_px) {
    for (double& o : per_view) o /= previous_scale;
  }
  return Solution{std::move(result), std::move(finest_model_points),
                  std::move(finest_offset_directions), std::move(maps)};
}

std::vector<int> Registrar::relativeParents(const std::vector<bool>& diverged) const {
  std::vector<int> parent(bones_.size(), -1);
  if (settings_.parameterisation != RegistrationSettings::Parameterisation::kParentRelative) {
    return parent;
  }
  std::vector<bool> carries(bones_.size(), false);  // the parent of a relative child
  for (const auto& joint : joints_) {
    const auto p = static_cast<std::size_t>(joint.parent);
    const auto c = static_cast<std::size_t>(joint.child);
    if (diverged[p] || diverged[c] || parent[c] >= 0 || carries[c] || parent[p] >= 0) continue;
    parent[c] = joint.parent;
    carries[p] = true;
  }
  return parent;
}

void Registrar::finish(const std::vector<ViewImage>& views, Solution* solution) const {
  RegistrationResult& result = solution->result;
  const std::vector<imaging::EdgeMap>& maps = solution->maps;
  result.joints.clear();
  result.quality.clear();
  for (const auto& joint : joints_) {
    JointResult joint_result;
    joint_result.parent = joint.parent;
    joint_result.child = joint.child;
    const geometry::Pose& parent_pose = result.poses[joint.parent];
    const geometry::Pose& child_pose = result.poses[joint.child];
    joint_result.coordinates = joint.coordinates(parent_pose, child_pose);
    if (joint.contact) {
      joint_result.has_contact = true;
      // FCL's separation is added to the solution solve() returns only (addSeparation).
      joint_result.contact = joint.contact->sampledFigures(parent_pose, child_pose, true);
      joint_result.quality.penetration_m = joint_result.contact.max_depth_m;
    }
    if (joint.ligaments.enabled) {
      joint_result.quality.envelope_violation = joint.envelopeViolation(parent_pose, child_pose);
    }
    result.joints.push_back(joint_result);
  }
  // Each bone's silhouette per view, on the final map's pixels, for what covers what.
  std::vector<std::vector<cv::Mat>> silhouettes(views.size(), std::vector<cv::Mat>(bones_.size()));
  for (std::size_t v = 0; v < maps.size() && bones_.size() > 1; ++v) {
    const geometry::XrayCamera& camera = maps[v].camera();
    const geometry::Pose camera_from_fixed = camera.worldFromCamera().inverse();
    for (std::size_t b = 0; b < bones_.size(); ++b) {
      if (result.diverged[b]) continue;
      silhouettes[v][b] = bones_[b].silhouette->mask(camera, camera_from_fixed * result.poses[b]);
    }
  }
  for (std::size_t b = 0; b < bones_.size(); ++b) {
    std::vector<std::vector<const cv::Mat*>> covering(views.size());
    for (std::size_t v = 0; v < maps.size(); ++v) {
      for (std::size_t o = 0; o < bones_.size(); ++o) {
        if (o != b && !silhouettes[v][o].empty()) covering[v].push_back(&silhouettes[v][o]);
      }
    }
    result.quality.push_back(imageQuality(
        *bones_[b].silhouette, result.poses[b], maps, solution->contour_model_points[b],
        solution->contour_offset_directions[b],
        b < result.edge_offsets_px.size() ? result.edge_offsets_px[b] : std::vector<double>(),
        settings_.edge_offset_model, covering, settings_.quality, settings_.compute_covariance));
    if (b < result.covariance_valid.size() && result.covariance_valid[b]) {
      // The solver counts every contour sample as independent; neighbours share blur, the
      // silhouette's shape and the edge offset's pattern along it (see BoneQuality).
      result.covariances[b] *= result.quality.back().residual_correlation_samples;
      if (b < result.offset_gradient_covariances.size()) {
        result.covariances[b] += result.offset_gradient_covariances[b];
      }
      addCovarianceQuality(result.covariances[b], result.poses[b], views.front().camera,
                           &result.quality.back());
    }
  }
}

}  // namespace registration
}  // namespace fluoro_tracker
