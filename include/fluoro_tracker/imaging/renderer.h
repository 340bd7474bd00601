#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/geometry/xray_camera.h"

namespace fluoro_tracker {
namespace imaging {

// A closed mesh placed in a view, with its material's attenuation.
struct RenderObject {
  const geometry::Mesh* mesh = nullptr;
  geometry::Pose camera_from_mesh = geometry::Pose::Identity();  // optical frame <- mesh frame
  double attenuation_per_mm = 0.0;
};

// Projects closed meshes through an X-ray view and integrates, per pixel, the path length of
// the source ray through each mesh. For a closed, outward-oriented mesh the sum over its
// triangles of ±(distance to the triangle along the ray), + where the ray leaves and − where
// it enters, is exactly the length inside the mesh, however many times the ray crosses it.
// Triangles are rasterised in fixed point with a top-left rule, so each pixel's sample point
// is counted once by the triangles sharing an edge and the sums stay exact. Where a surface is
// seen exactly edge-on, snapped slivers can still break that at an isolated sample, so each
// mesh's lengths are clamped to [0, its bounding-box diagonal], which bounds such a pixel.
class Renderer {
 public:
  // Pixel (u, v) is sampled by the ray through (u + kSampleOffsetPx, v + kSampleOffsetPx): a
  // hair off the centre, off the grid that projected vertices are snapped to (see renderer.cpp).
  static constexpr double kSampleOffsetPx = 1.0 / 512.0;

  // Path length in metres (CV_64F, camera-sized) through one mesh.
  static cv::Mat pathLength(const geometry::XrayCamera& camera, const geometry::Mesh& mesh,
                            const geometry::Pose& camera_from_mesh);

  // Silhouette mask (CV_8U, 255 where the ray crosses the mesh): the union of the front-facing
  // triangles' projections (every ray that meets a closed mesh enters through one).
  static cv::Mat coverage(const geometry::XrayCamera& camera, const geometry::Mesh& mesh,
                          const geometry::Pose& camera_from_mesh);

  // Attenuation line integral Σ μ·L (dimensionless, CV_64F) through all objects.
  static cv::Mat lineIntegral(const geometry::XrayCamera& camera,
                              const std::vector<RenderObject>& objects);

  // Adds weight × (path parameter along the z=1-normalised ray) of one mesh to `accumulator`
  // (CV_64F, camera-sized) and returns the pixel rectangle it touched. Multiply the result by
  // |ray| per pixel (finishRayLengths) to get lengths. Throws InputError if a vertex lies at or
  // behind the source plane.
  static cv::Rect accumulate(const geometry::XrayCamera& camera, const geometry::Mesh& mesh,
                             const geometry::Pose& camera_from_mesh, double weight,
                             cv::Mat* accumulator);
  static void finishRayLengths(const geometry::XrayCamera& camera, cv::Mat* accumulator,
                               cv::Rect region = cv::Rect());
};

}  // namespace imaging
}  // namespace fluoro_tracker
