#include "fluoro_tracker/imaging/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {
namespace {

constexpr int kSubpixelBits = 8;
constexpr std::int64_t kSubpixel = 1 << kSubpixelBits;
// Vertices closer than this to the source plane have no usable projection.
constexpr double kMinDepthM = 1e-3;
// Keeps the fixed-point edge functions inside 64 bits.
constexpr double kMaxPixelCoordinate = 4e6;

struct FixedPoint {
  std::int64_t x;
  std::int64_t y;
};

// Top-left rule for an edge a->b of a triangle with positive signed area (x right, y down):
// pixel centres exactly on the edge belong to this triangle only for these edge directions,
// so two triangles sharing the edge (which traverse it in opposite directions) never both
// claim a centre.
bool ownsEdge(const FixedPoint& a, const FixedPoint& b) {
  const std::int64_t dx = b.x - a.x;
  const std::int64_t dy = b.y - a.y;
  return dy > 0 || (dy == 0 && dx < 0);
}

}  // namespace

void Renderer::accumulate(const geometry::XrayCamera& camera, const geometry::Mesh& mesh,
                          const geometry::Pose& camera_from_mesh, double weight,
                          cv::Mat* accumulator) {
  CV_Assert(accumulator->type() == CV_64F && accumulator->rows == camera.height() &&
            accumulator->cols == camera.width());
  const auto& vertices = mesh.vertices();
  std::vector<Eigen::Vector3d> points(vertices.size());
  std::vector<FixedPoint> pixels(vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    points[i] = camera_from_mesh * vertices[i];
    if (!(points[i].z() > kMinDepthM)) {
      throw InputError("cannot render: a mesh vertex lies at or behind the X-ray source plane of " +
                       camera.frameId() + " (z = " + std::to_string(points[i].z()) + " m)");
    }
    const double u = camera.fx() * points[i].x() / points[i].z() + camera.cx();
    const double v = camera.fy() * points[i].y() / points[i].z() + camera.cy();
    if (std::abs(u) > kMaxPixelCoordinate || std::abs(v) > kMaxPixelCoordinate) {
      throw InputError("cannot render: a mesh vertex projects " + std::to_string(std::hypot(u, v)) +
                       " pixels from the image origin in " + camera.frameId() +
                       " (mesh too close to the source?)");
    }
    pixels[i] = {std::llround(u * kSubpixel), std::llround(v * kSubpixel)};
  }

  const int width = camera.width();
  const int height = camera.height();
  const double inv_fx = 1.0 / camera.fx();
  const double inv_fy = 1.0 / camera.fy();

  for (const auto& t : mesh.triangles()) {
    FixedPoint a = pixels[t[0]];
    FixedPoint b = pixels[t[1]];
    FixedPoint c = pixels[t[2]];
    std::int64_t area2 = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (area2 == 0) continue;  // edge-on: covers no pixel centre
    if (area2 < 0) std::swap(b, c);

    // Pixel-centre bounding box, clipped to the image.
    const std::int64_t min_x = std::min({a.x, b.x, c.x});
    const std::int64_t max_x = std::max({a.x, b.x, c.x});
    const std::int64_t min_y = std::min({a.y, b.y, c.y});
    const std::int64_t max_y = std::max({a.y, b.y, c.y});
    const int u0 = std::max<std::int64_t>(0, (min_x + kSubpixel - 1) >> kSubpixelBits);
    const int u1 = std::min<std::int64_t>(width - 1, max_x >> kSubpixelBits);
    const int v0 = std::max<std::int64_t>(0, (min_y + kSubpixel - 1) >> kSubpixelBits);
    const int v1 = std::min<std::int64_t>(height - 1, max_y >> kSubpixelBits);
    if (u0 > u1 || v0 > v1) continue;

    // Plane of the triangle in the optical frame: n·p = n·p0. Along the ray r = (x, y, 1) with
    // x = (u - cx)/fx, y = (v - cy)/fy the plane is met at parameter s = n·p0 / n·r, and the
    // signed contribution (+ leaving, − entering) is n·p0 / |n·r|.
    const Eigen::Vector3d& p0 = points[t[0]];
    const Eigen::Vector3d n = (points[t[1]] - p0).cross(points[t[2]] - p0);
    const double numerator = weight * n.dot(p0);
    const double du = n.x() * inv_fx;  // d(n·r)/du
    const double dv = n.y() * inv_fy;  // d(n·r)/dv
    const double c0 = n.z() - n.x() * camera.cx() * inv_fx - n.y() * camera.cy() * inv_fy;

    // Edge functions E_ab(p) = (b - a) × (p - a) at the first pixel centre, stepped per pixel.
    const FixedPoint edges[3][2] = {{b, c}, {c, a}, {a, b}};
    std::int64_t row_value[3];
    std::int64_t step_u[3];
    std::int64_t step_v[3];
    const std::int64_t px = static_cast<std::int64_t>(u0) << kSubpixelBits;
    const std::int64_t py = static_cast<std::int64_t>(v0) << kSubpixelBits;
    for (int e = 0; e < 3; ++e) {
      const FixedPoint& ea = edges[e][0];
      const FixedPoint& eb = edges[e][1];
      const std::int64_t bias = ownsEdge(ea, eb) ? 0 : -1;
      row_value[e] = (eb.x - ea.x) * (py - ea.y) - (eb.y - ea.y) * (px - ea.x) + bias;
      step_u[e] = -(eb.y - ea.y) * kSubpixel;
      step_v[e] = (eb.x - ea.x) * kSubpixel;
    }
    for (int v = v0; v <= v1; ++v) {
      // The covered pixels of this row form one span; find it exactly from the integer edge
      // functions (w_e + k * step_u[e] >= 0 for k pixels right of u0) instead of testing every
      // pixel of the bounding box, which long sliver triangles make huge.
      std::int64_t k_min = 0;
      std::int64_t k_max = u1 - u0;
      for (int e = 0; e < 3 && k_min <= k_max; ++e) {
        const std::int64_t w = row_value[e];
        const std::int64_t step = step_u[e];
        if (step > 0) {
          if (w < 0) k_min = std::max(k_min, (-w + step - 1) / step);
        } else if (step < 0) {
          if (w < 0) {
            k_max = -1;
          } else {
            k_max = std::min(k_max, w / -step);
          }
        } else if (w < 0) {
          k_max = -1;
        }
      }
      double* row = accumulator->ptr<double>(v);
      const double row_denominator = dv * v + c0;
      for (std::int64_t k = k_min; k <= k_max; ++k) {
        const int u = u0 + static_cast<int>(k);
        row[u] += numerator / std::abs(du * u + row_denominator);
      }
      for (int e = 0; e < 3; ++e) row_value[e] += step_v[e];
    }
  }
}

void Renderer::finishRayLengths(const geometry::XrayCamera& camera, cv::Mat* accumulator) {
  for (int v = 0; v < accumulator->rows; ++v) {
    double* row = accumulator->ptr<double>(v);
    const double y = (v - camera.cy()) / camera.fy();
    for (int u = 0; u < accumulator->cols; ++u) {
      if (row[u] == 0.0) continue;
      const double x = (u - camera.cx()) / camera.fx();
      row[u] *= std::sqrt(x * x + y * y + 1.0);
    }
  }
}

cv::Mat Renderer::pathLength(const geometry::XrayCamera& camera, const geometry::Mesh& mesh,
                             const geometry::Pose& camera_from_mesh) {
  cv::Mat result = cv::Mat::zeros(camera.height(), camera.width(), CV_64F);
  accumulate(camera, mesh, camera_from_mesh, 1.0, &result);
  finishRayLengths(camera, &result);
  return result;
}

cv::Mat Renderer::lineIntegral(const geometry::XrayCamera& camera,
                               const std::vector<RenderObject>& objects) {
  cv::Mat result = cv::Mat::zeros(camera.height(), camera.width(), CV_64F);
  for (const auto& object : objects) {
    if (object.mesh == nullptr || object.mesh->empty()) continue;
    // Attenuation per mm times path length in m.
    accumulate(camera, *object.mesh, object.camera_from_mesh, 1e3 * object.attenuation_per_mm,
               &result);
  }
  finishRayLengths(camera, &result);
  return result;
}

}  // namespace imaging
}  // namespace fluoro_tracker
