#include "fluoro_tracker/registration/image_shift_search.h"

#include <algorithm>
#include <cmath>

namespace fluoro_tracker {
namespace registration {
namespace {

constexpr float kTruncationPx = 3.0f;

}  // namespace

std::optional<std::vector<geometry::Pose>> posesShiftedToEdges(
    const std::vector<BoneModel>& bones, const std::vector<geometry::Pose>& poses,
    const ViewImage& view, const imaging::EdgeMapSettings& edges, double max_shift_m,
    double scale) {
  if (bones.size() != poses.size() || poses.empty() || !(max_shift_m > 0.0)) return std::nullopt;
  const imaging::EdgeMap map(view.image, view.camera, edges, cv::Rect(), scale);
  const geometry::XrayCamera& camera = map.camera();
  const cv::Mat distance = map.unsignedDistance(kTruncationPx);
  const geometry::Pose world_from_camera = camera.worldFromCamera();
  const geometry::Pose camera_from_world = world_from_camera.inverse();

  std::vector<cv::Point> samples;
  double depth = 0.0;
  for (std::size_t b = 0; b < bones.size(); ++b) {
    const geometry::Pose camera_from_mesh = camera_from_world * poses[b];
    depth += camera_from_mesh.translation().z() / static_cast<double>(bones.size());
    if (camera_from_mesh.translation().z() <= 0.0) return std::nullopt;
    for (const auto& c : bones[b].silhouette->contour(camera, camera_from_mesh, 1.0)) {
      samples.emplace_back(static_cast<int>(std::floor(c.pixel.x() + 0.5)),
                           static_cast<int>(std::floor(c.pixel.y() + 0.5)));
    }
  }
  if (samples.empty()) return std::nullopt;
  // Shifts within max_shift_m at the bones' mean depth: an ellipse of pixels (fx may differ from
  // fy).
  const double reach_x = max_shift_m * camera.fx() / depth;
  const double reach_y = max_shift_m * camera.fy() / depth;
  const int reach_u = static_cast<int>(std::floor(reach_x));
  const int reach_v = static_cast<int>(std::floor(reach_y));

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
  if (std::abs(best_dx) <= 1 && std::abs(best_dy) <= 1) return std::nullopt;
  const Eigen::Vector3d step(best_dx * depth / camera.fx(), best_dy * depth / camera.fy(), 0.0);
  const geometry::Pose moved = world_from_camera * Eigen::Translation3d(step) * camera_from_world;
  std::vector<geometry::Pose> shifted;
  shifted.reserve(poses.size());
  for (const geometry::Pose& pose : poses) shifted.push_back(moved * pose);
  return shifted;
}

}  // namespace registration
}  // namespace fluoro_tracker
