#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/geometry/xray_camera.h"

namespace fluoro_tracker {
namespace imaging {

// One sample of a projected outer contour.
struct ContourPoint {
  Eigen::Vector3d model_point;  // on the mesh, in the mesh frame (moves with the pose)
  Eigen::Vector2d pixel;        // its projection at the pose the contour was extracted at
  Eigen::Vector2d normal;       // unit, in the image, pointing out of the silhouette
};

// A silhouette mask over part of a view: `mask` (CV_8U, 255 inside the silhouette) covers the
// view's pixels from `origin` on.
struct SilhouetteCrop {
  cv::Mat mask;
  cv::Point origin;
};

// Outer contour of a closed mesh seen by an X-ray view. What can be precomputed per mesh is:
// its edges with their two faces (for contour generators: edges between a face turned toward
// the source and one turned away). At a pose, the contour generators are projected and sampled,
// and samples that are not on the outer boundary of the projected silhouette (hidden rims,
// inner folds) are dropped by testing the silhouette mask on both sides. The mask itself is
// filled from the contour generators alone (see mask()), not by rasterising every face.
class SilhouetteModel {
 public:
  explicit SilhouetteModel(const geometry::Mesh& mesh);

  const geometry::Mesh& mesh() const { return mesh_; }
  // The mesh's bounding box (its frame), kept: registration asks for it every outer iteration.
  const Eigen::AlignedBox3d& bounds() const { return bounds_; }

  // Contour samples about every `spacing_px` pixels of `camera`. Points outside the camera's
  // image are dropped. `crop`, if given, receives the silhouette mask the samples were tested
  // against: the same pixels as mask(), over the silhouette's bounds and 3 pixels around them
  // (clipped to the image; empty when the silhouette is outside it).
  std::vector<ContourPoint> contour(const geometry::XrayCamera& camera,
                                    const geometry::Pose& camera_from_mesh, double spacing_px = 1.0,
                                    SilhouetteCrop* crop = nullptr) const;

  // Silhouette mask (CV_8U, camera-sized, 255 where the ray through the pixel's sample point,
  // offset Renderer::kSampleOffsetPx from its centre, crosses the mesh): the same pixels as
  // Renderer::coverage but for samples within a rounding error of the outline. Throws
  // InputError for a vertex behind the source.
  cv::Mat mask(const geometry::XrayCamera& camera, const geometry::Pose& camera_from_mesh) const;

 private:
  // A contour generator: an edge between a face turned toward the source and one turned away,
  // directed as the face toward the source runs along it.
  struct DirectedEdge {
    int from;
    int to;
  };
  // The mesh seen from a view: its vertices' pixels, their bounds, and its contour generators.
  struct Projection {
    std::vector<Eigen::Vector2d> pixels;
    Eigen::AlignedBox2d bounds;
    std::vector<DirectedEdge> contour_generators;
  };
  Projection project(const geometry::XrayCamera& camera,
                     const geometry::Pose& camera_from_mesh) const;
  // The mask of the silhouette over the pixels [x0, x0 + width) x [y0, y0 + height) of the
  // projection's image, as a width x height image.
  cv::Mat fillSilhouette(const Projection& projection, int x0, int y0, int width, int height) const;

  struct Edge {
    int a;
    int b;
    int face_left;
    int face_right;
  };
  geometry::Mesh mesh_;
  Eigen::AlignedBox3d bounds_;
  std::vector<Edge> edges_;
};

}  // namespace imaging
}  // namespace fluoro_tracker
