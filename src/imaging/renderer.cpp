#include "fluoro_tracker/imaging/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace imaging {
namespace {

// Fixed point with 1/512-pixel units: vertices are snapped to even units (a 1/256-pixel grid)
// and every pixel is sampled at odd units, (u + 1/512, v + 1/512), so a projected vertex never
// coincides with a sample point. Where a fan of triangles folds over itself in projection
// (a surface seen edge-on), ownership of a sample exactly on a shared vertex could not be made
// consistent, and an entry would be counted without its exit.
constexpr int kSubpixelBits = 9;
constexpr std::int64_t kSubpixel = 1 << kSubpixelBits;
// Vertices closer than this to the source plane have no usable projection.
constexpr double kMinDepthM = 1e-3;
constexpr double kSampleOffset = Renderer::kSampleOffsetPx;
// Keeps the fixed-point edge functions inside 64 bits.
constexpr double kMaxPixelCoordinate = 2e6;

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

// Projects every vertex into `camera` (optical-frame points and snapped fixed-point pixels).
// Throws InputError for a vertex at or behind the source plane or projecting absurdly far.
void projectVertices(const geometry::XrayCamera& camera, const geometry::Mesh& mesh,
                     const geometry::Pose& camera_from_mesh, std::vector<Eigen::Vector3d>* points,
                     std::vector<FixedPoint>* pixels) {
  const auto& vertices = mesh.vertices();
  points->resize(vertices.size());
  pixels->resize(vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const Eigen::Vector3d p = camera_from_mesh * vertices[i];
    (*points)[i] = p;
    if (!(p.z() > kMinDepthM)) {
      throw InputError("cannot render: a mesh vertex lies at or behind the X-ray source plane of " +
                       camera.frameId() + " (z = " + std::to_string(p.z()) + " m)");
    }
    const double u = camera.fx() * p.x() / p.z() + camera.cx();
    const double v = camera.fy() * p.y() / p.z() + camera.cy();
    if (std::abs(u) > kMaxPixelCoordinate || std::abs(v) > kMaxPixelCoordinate) {
      throw InputError("cannot render: a mesh vertex projects " + std::to_string(std::hypot(u, v)) +
                       " pixels from the image origin in " + camera.frameId() +
                       " (mesh too close to the source?)");
    }
    (*pixels)[i] = {2 * std::llround(u * (kSubpixel / 2)), 2 * std::llround(v * (kSubpixel / 2))};
  }
}

// Rasterises one projected triangle: calls span(v, u_first, u_last) for each image row v whose
// sample points in [u_first, u_last] the triangle covers (top-left rule on shared edges), and
// adds the pixel box it may touch to `touched`. Edge-on triangles cover nothing.
template <typename SpanFunction>
void rasterizeTriangle(FixedPoint a, FixedPoint b, FixedPoint c, int width, int height,
                       cv::Rect* touched, SpanFunction&& span) {
  const std::int64_t area2 = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
  if (area2 == 0) return;  // edge-on: covers no pixel centre
  if (area2 < 0) std::swap(b, c);

  // Pixel-centre bounding box, clipped to the image.
  const std::int64_t min_x = std::min({a.x, b.x, c.x});
  const std::int64_t max_x = std::max({a.x, b.x, c.x});
  const std::int64_t min_y = std::min({a.y, b.y, c.y});
  const std::int64_t max_y = std::max({a.y, b.y, c.y});
  // Pixels whose sample point (u * kSubpixel + 1) lies within the box.
  const int u0 = std::max<std::int64_t>(0, (min_x - 1 + kSubpixel - 1) >> kSubpixelBits);
  const int u1 = std::min<std::int64_t>(width - 1, (max_x - 1) >> kSubpixelBits);
  const int v0 = std::max<std::int64_t>(0, (min_y - 1 + kSubpixel - 1) >> kSubpixelBits);
  const int v1 = std::min<std::int64_t>(height - 1, (max_y - 1) >> kSubpixelBits);
  if (u0 > u1 || v0 > v1) return;
  *touched |= cv::Rect(u0, v0, u1 - u0 + 1, v1 - v0 + 1);

  // Edge functions E_ab(p) = (b - a) × (p - a) at the first pixel centre, stepped per pixel.
  const FixedPoint edges[3][2] = {{b, c}, {c, a}, {a, b}};
  std::int64_t row_value[3];
  std::int64_t step_u[3];
  std::int64_t step_v[3];
  const std::int64_t px = (static_cast<std::int64_t>(u0) << kSubpixelBits) + 1;
  const std::int64_t py = (static_cast<std::int64_t>(v0) << kSubpixelBits) + 1;
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
    if (k_min <= k_max) span(v, u0 + static_cast<int>(k_min), u0 + static_cast<int>(k_max));
    for (int e = 0; e < 3; ++e) row_value[e] += step_v[e];
  }
}

}  // namespace

cv::Rect Renderer::accumulate(const geometry::XrayCamera& camera, const geometry::Mesh& mesh,
                              const geometry::Pose& camera_from_mesh, double weight,
                              cv::Mat* accumulator) {
  cv::Rect touched;
  CV_Assert(accumulator->type() == CV_64F && accumulator->rows == camera.height() &&
            accumulator->cols == camera.width());
  std::vector<Eigen::Vector3d> points;
  std::vector<FixedPoint> pixels;
  projectVertices(camera, mesh, camera_from_mesh, &points, &pixels);
  const double inv_fx = 1.0 / camera.fx();
  const double inv_fy = 1.0 / camera.fy();

  for (const auto& t : mesh.triangles()) {
    // Plane of the triangle in the optical frame: n·p = n·p0. Along the ray r = (x, y, 1) with
    // x = (u - cx)/fx, y = (v - cy)/fy the plane is met at parameter s = n·p0 / n·r (the hit's
    // depth z), and the signed contribution is +s where the ray leaves (n·r > 0), −s where it
    // enters.
    const Eigen::Vector3d& p0 = points[t[0]];
    const Eigen::Vector3d n = (points[t[1]] - p0).cross(points[t[2]] - p0);
    const double plane_offset = n.dot(p0);
    // The ray meets a covered triangle inside it, so the hit depth lies within the triangle's
    // depth range. Clamping to it is exact for genuine hits and keeps a triangle seen almost
    // exactly edge-on (n·r ~ 0 after vertex snapping) from adding an unbounded value.
    const double z_min = std::min({p0.z(), points[t[1]].z(), points[t[2]].z()});
    const double z_max = std::max({p0.z(), points[t[1]].z(), points[t[2]].z()});
    const double du = n.x() * inv_fx;  // d(n·r)/du
    const double dv = n.y() * inv_fy;  // d(n·r)/dv
    const double c0 = n.z() - n.x() * camera.cx() * inv_fx - n.y() * camera.cy() * inv_fy;
    rasterizeTriangle(pixels[t[0]], pixels[t[1]], pixels[t[2]], camera.width(), camera.height(),
                      &touched, [&](int v, int u_first, int u_last) {
                        double* row = accumulator->ptr<double>(v);
                        const double row_denominator = dv * (v + kSampleOffset) + c0;
                        for (int u = u_first; u <= u_last; ++u) {
                          const double n_dot_r = du * (u + kSampleOffset) + row_denominator;
                          const double depth = std::clamp(plane_offset / n_dot_r, z_min, z_max);
                          row[u] += n_dot_r > 0.0 ? weight * depth : -weight * depth;
                        }
                      });
  }
  return touched;
}

void Renderer::finishRayLengths(const geometry::XrayCamera& camera, cv::Mat* accumulator,
                                cv::Rect region) {
  if (region.area() == 0) region = cv::Rect(0, 0, accumulator->cols, accumulator->rows);
  for (int v = region.y; v < region.y + region.height; ++v) {
    double* row = accumulator->ptr<double>(v);
    const double y = (v + kSampleOffset - camera.cy()) / camera.fy();
    for (int u = region.x; u < region.x + region.width; ++u) {
      if (row[u] == 0.0) continue;
      const double x = (u + kSampleOffset - camera.cx()) / camera.fx();
      row[u] *= std::sqrt(x * x + y * y + 1.0);
    }
  }
}

namespace {

// Renders one mesh's path lengths into `scratch` (zero on entry), clamps them to the physically
// possible range, adds weight × length to `accumulator` and zeroes `scratch` again.
void addMeshPathLength(const geometry::XrayCamera& camera, const geometry::Mesh& mesh,
                       const geometry::Pose& camera_from_mesh, double weight, cv::Mat* scratch,
                       cv::Mat* accumulator) {
  const cv::Rect region = Renderer::accumulate(camera, mesh, camera_from_mesh, 1.0, scratch);
  if (region.area() == 0) return;
  Renderer::finishRayLengths(camera, scratch, region);
  cv::Mat lengths = (*scratch)(region);
  const double longest = mesh.bounds().sizes().norm();
  cv::min(cv::max(lengths, 0.0), longest, lengths);
  cv::scaleAdd(lengths, weight, (*accumulator)(region), (*accumulator)(region));
  lengths.setTo(0.0);
}

}  // namespace

cv::Mat Renderer::pathLength(const geometry::XrayCamera& camera, const geometry::Mesh& mesh,
                             const geometry::Pose& camera_from_mesh) {
  cv::Mat result = cv::Mat::zeros(camera.height(), camera.width(), CV_64F);
  cv::Mat scratch = cv::Mat::zeros(camera.height(), camera.width(), CV_64F);
  addMeshPathLength(camera, mesh, camera_from_mesh, 1.0, &scratch, &result);
  return result;
}

cv::Mat Renderer::coverage(const geometry::XrayCamera& camera, const geometry::Mesh& mesh,
                           const geometry::Pose& camera_from_mesh) {
  // Every ray that meets a closed mesh enters it through a front-facing triangle, so the union
  // of the front-facing triangles' projections is the silhouette: filling their spans needs no
  // depths, and back faces (about half) are skipped.
  std::vector<Eigen::Vector3d> points;
  std::vector<FixedPoint> pixels;
  projectVertices(camera, mesh, camera_from_mesh, &points, &pixels);
  cv::Mat mask = cv::Mat::zeros(camera.height(), camera.width(), CV_8U);
  cv::Rect touched;
  for (const auto& t : mesh.triangles()) {
    const Eigen::Vector3d& p0 = points[t[0]];
    const Eigen::Vector3d n = (points[t[1]] - p0).cross(points[t[2]] - p0);
    if (!(n.dot(p0) < 0.0)) continue;  // seen from behind or edge-on: the ray leaves here
    rasterizeTriangle(pixels[t[0]], pixels[t[1]], pixels[t[2]], camera.width(), camera.height(),
                      &touched, [&](int v, int u_first, int u_last) {
                        std::uint8_t* row = mask.ptr<std::uint8_t>(v);
                        std::fill(row + u_first, row + u_last + 1, std::uint8_t{255});
                      });
  }
  return mask;
}

cv::Mat Renderer::lineIntegral(const geometry::XrayCamera& camera,
                               const std::vector<RenderObject>& objects) {
  cv::Mat result = cv::Mat::zeros(camera.height(), camera.width(), CV_64F);
  cv::Mat scratch = cv::Mat::zeros(camera.height(), camera.width(), CV_64F);
  for (const auto& object : objects) {
    if (object.mesh == nullptr || object.mesh->empty()) continue;
    // Attenuation per mm times path length in m.
    addMeshPathLength(camera, *object.mesh, object.camera_from_mesh,
                      1e3 * object.attenuation_per_mm, &scratch, &result);
  }
  return result;
}

}  // namespace imaging
}  // namespace fluoro_tracker
