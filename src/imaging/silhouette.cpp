#include "fluoro_tracker/imaging/silhouette.h"

#include <cmath>
#include <unordered_map>

#include "fluoro_tracker/imaging/renderer.h"
#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {
namespace {

// Offset (pixels) at which the mask is probed on either side of a contour sample.
constexpr double kProbePx = 1.5;

}  // namespace

SilhouetteModel::SilhouetteModel(const geometry::Mesh& mesh)
    : mesh_(mesh), face_normals_(mesh.faceNormals()) {
  if (!mesh.topology().isClosed()) {
    throw InputError("silhouette: the mesh must be closed and consistently oriented");
  }
  std::unordered_map<std::uint64_t, int> first_face;
  const auto& triangles = mesh.triangles();
  for (int f = 0; f < static_cast<int>(triangles.size()); ++f) {
    for (int k = 0; k < 3; ++k) {
      const int a = triangles[f][k];
      const int b = triangles[f][(k + 1) % 3];
      const std::uint64_t key = geometry::undirectedEdgeKey(a, b);
      auto it = first_face.find(key);
      if (it == first_face.end()) {
        first_face.emplace(key, f);
      } else {
        edges_.push_back({a, b, it->second, f});
      }
    }
  }
}

std::vector<ContourPoint> SilhouetteModel::contour(const geometry::XrayCamera& camera,
                                                   const geometry::Pose& camera_from_mesh,
                                                   double spacing_px) const {
  const auto& vertices = mesh_.vertices();
  std::vector<Eigen::Vector3d> points(vertices.size());
  std::vector<Eigen::Vector2d> pixels(vertices.size());
  Eigen::AlignedBox2d box;
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    points[i] = camera_from_mesh * vertices[i];
    if (!camera.project(points[i], &pixels[i])) {
      throw InputError("silhouette: a mesh vertex lies behind the X-ray source of " +
                       camera.frameId());
    }
    box.extend(pixels[i]);
  }

  // Silhouette mask of the mesh, rendered in a crop around its projection.
  const int margin = 3;
  const int x0 = std::max(0, static_cast<int>(std::floor(box.min().x())) - margin);
  const int y0 = std::max(0, static_cast<int>(std::floor(box.min().y())) - margin);
  const int x1 = std::min(camera.width() - 1, static_cast<int>(std::ceil(box.max().x())) + margin);
  const int y1 = std::min(camera.height() - 1, static_cast<int>(std::ceil(box.max().y())) + margin);
  std::vector<ContourPoint> out;
  if (x1 <= x0 || y1 <= y0) return out;  // entirely outside the image
  const geometry::XrayCamera crop = camera.cropped(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
  const cv::Mat mask = Renderer::coverage(crop, mesh_, camera_from_mesh);
  const auto covered = [&](const Eigen::Vector2d& p) {
    // Nearest pixel (floor of x + 0.5: std::lround's library call was a tenth of this loop).
    const int u = static_cast<int>(std::floor(p.x() + 0.5)) - x0;
    const int v = static_cast<int>(std::floor(p.y() + 0.5)) - y0;
    if (u < 0 || v < 0 || u >= mask.cols || v >= mask.rows) return false;
    return mask.at<std::uint8_t>(v, u) != 0;
  };

  // Face normals turned into the camera frame once (each face borders three edges).
  const Eigen::Matrix3d rotation = camera_from_mesh.linear();
  std::vector<Eigen::Vector3d> normals(face_normals_.size());
  for (std::size_t f = 0; f < face_normals_.size(); ++f) normals[f] = rotation * face_normals_[f];
  for (const Edge& e : edges_) {
    // Facing relative to the ray from the source to a vertex of each face.
    const Eigen::Vector3d& ray = points[e.a];
    const bool left_front = normals[e.face_left].dot(ray) < 0.0;
    const bool right_front = normals[e.face_right].dot(ray) < 0.0;
    if (left_front == right_front) continue;
    const Eigen::Vector2d pa = pixels[e.a];
    const Eigen::Vector2d pb = pixels[e.b];
    const Eigen::Vector2d d = pb - pa;
    const double length = d.norm();
    if (length < 1e-9) continue;
    const Eigen::Vector2d perpendicular(-d.y() / length, d.x() / length);
    const int samples = std::max(1, static_cast<int>(std::ceil(length / spacing_px)));
    for (int k = 0; k < samples; ++k) {
      const double t = (k + 0.5) / samples;
      const Eigen::Vector2d p = pa + t * d;
      if (!camera.contains(p)) continue;
      const bool plus = covered(p + kProbePx * perpendicular);
      const bool minus = covered(p - kProbePx * perpendicular);
      if (plus == minus) continue;  // inside the silhouette (hidden rim) or a stray sample
      ContourPoint c;
      c.model_point = (1.0 - t) * vertices[e.a] + t * vertices[e.b];
      c.pixel = p;
      c.normal = plus ? Eigen::Vector2d(-perpendicular) : perpendicular;
      out.push_back(c);
    }
  }
  return out;
}

}  // namespace imaging
}  // namespace fluoro_tracker
