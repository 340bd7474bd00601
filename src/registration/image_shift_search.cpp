#include "fluoro_tracker/registration/image_shift_search.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace fluoro_tracker {
namespace registration {
namespace {

constexpr float kTruncationPx = 3.0f;

// One view's answer: the best shift of the bones' contours (map pixels) and what a pixel is at
// the bones' depth there.
struct ViewShift {
  Eigen::Vector2d shift_px;
  geometry::Pose camera_from_world;
  double depth_m;
  double fx;
  double fy;
};

// The shift of all bones' contours together, within max_shift_m at their mean depth, whose
// samples lie nearest the view's edges (mean chamfer distance); nothing when no bone is in the
// view.
std::optional<ViewShift> bestShift(const std::vector<BoneModel>& bones,
                                   const std::vector<geometry::Pose>& poses, const ViewImage& view,
                                   const imaging::EdgeMapSettings& edges, double max_shift_m,
                                   double scale) {
  const imaging::EdgeMap map(view.image, view.camera, edges, cv::Rect(), scale);
  const geometry::XrayCamera& camera = map.camera();
  const geometry::Pose camera_from_world = camera.worldFromCamera().inverse();
  std::vector<cv::Point> samples;
  double depth = 0.0;
  for (std::size_t b = 0; b < bones.size(); ++b) {
    const geometry::Pose camera_from_mesh = camera_from_world * poses[b];
    if (camera_from_mesh.translation().z() <= 0.0) return std::nullopt;
    depth += camera_from_mesh.translation().z() / static_cast<double>(bones.size());
    for (const auto& c : bones[b].silhouette->contour(camera, camera_from_mesh, 1.0)) {
      samples.emplace_back(static_cast<int>(std::floor(c.pixel.x() + 0.5)),
                           static_cast<int>(std::floor(c.pixel.y() + 0.5)));
    }
  }
  if (samples.empty()) return std::nullopt;
  const cv::Mat distance = map.unsignedDistance(kTruncationPx);
  // Mean truncated chamfer distance of the contour moved by (dx, dy); samples moved off the map
  // count as far from every edge.
  const auto score = [&](int dx, int dy) {
    double sum = 0.0;
    for (const cv::Point& p : samples) {
      const int u = p.x + dx;
      const int v = p.y + dy;
      sum += (u < 0 || v < 0 || u >= distance.cols || v >= distance.rows)
                 ? kTruncationPx
                 : std::min(distance.at<float>(v, u), kTruncationPx);
    }
    return sum / static_cast<double>(samples.size());
  };
  // Shifts within max_shift_m at the bones' mean depth: an ellipse of pixels (fx may differ from
  // fy).
  const double reach_x = max_shift_m * camera.fx() / depth;
  const double reach_y = max_shift_m * camera.fy() / depth;
  const int reach_u = static_cast<int>(std::floor(reach_x));
  const int reach_v = static_cast<int>(std::floor(reach_y));
  double best = score(0, 0);
  int best_dx = 0;
  int best_dy = 0;
  for (int dy = -reach_v; dy <= reach_v; ++dy) {
    for (int dx = -reach_u; dx <= reach_u; ++dx) {
      if ((dx / reach_x) * (dx / reach_x) + (dy / reach_y) * (dy / reach_y) > 1.0) continue;
      const double s = score(dx, dy);
      if (s < best) {
        best = s;
        best_dx = dx;
        best_dy = dy;
      }
    }
  }
  return ViewShift{Eigen::Vector2d(best_dx, best_dy), camera_from_world, depth, camera.fx(),
                   camera.fy()};
}

}  // namespace

std::optional<std::vector<geometry::Pose>> posesShiftedToEdges(
    const std::vector<BoneModel>& bones, const std::vector<geometry::Pose>& poses,
    const std::vector<ViewImage>& views, const imaging::EdgeMapSettings& edges, double max_shift_m,
    double scale) {
  if (bones.size() != poses.size() || poses.empty() || !(max_shift_m > 0.0)) return std::nullopt;
  // Each view's shift, to first order, is its camera's x and y of the knee's translation t over
  // the knee's depth there: two equations per view. One view leaves t along its beam free (the
  // least-norm t has none); two or more fix it.
  std::vector<ViewShift> shifts;
  bool moved = false;
  for (const ViewImage& view : views) {
    const auto shift = bestShift(bones, poses, view, edges, max_shift_m, scale);
    if (!shift) continue;
    moved = moved || shift->shift_px.cwiseAbs().maxCoeff() > 1.0;
    shifts.push_back(*shift);
  }
  if (!moved) return std::nullopt;
  Eigen::MatrixXd a(2 * shifts.size(), 3);
  Eigen::VectorXd b(2 * shifts.size());
  for (std::size_t v = 0; v < shifts.size(); ++v) {
    const ViewShift& s = shifts[v];
    const Eigen::Matrix3d rotation = s.camera_from_world.linear();
    a.row(2 * v) = rotation.row(0) * s.fx / s.depth_m;
    a.row(2 * v + 1) = rotation.row(1) * s.fy / s.depth_m;
    b(2 * v) = s.shift_px.x();
    b(2 * v + 1) = s.shift_px.y();
  }
  const Eigen::Vector3d step = a.completeOrthogonalDecomposition().solve(b);
  if (!step.allFinite()) return std::nullopt;
  std::vector<geometry::Pose> shifted;
  shifted.reserve(poses.size());
  for (const geometry::Pose& pose : poses) {
    geometry::Pose moved_pose = pose;
    moved_pose.translation() += step;
    shifted.push_back(moved_pose);
  }
  return shifted;
}

}  // namespace registration
}  // namespace fluoro_tracker
