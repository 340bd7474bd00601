#pragma once

#include <vector>

#include <Eigen/Core>

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

// Outer contour of a closed mesh seen by an X-ray view. What can be precomputed per mesh is:
// its edges with their two faces (for contour generators: edges between a face turned toward
// the source and one turned away). At a pose, the contour generators are projected and sampled,
// and samples that are not on the outer boundary of the projected silhouette (hidden rims,
// inner folds) are dropped by testing the rendered silhouette mask on both sides.
class SilhouetteModel {
 public:
  explicit SilhouetteModel(const geometry::Mesh& mesh);

  const geometry::Mesh& mesh() const { return mesh_; }

  // Contour samples about every `spacing_px` pixels of `camera`. Points outside the camera's
  // image are dropped.
  std::vector<ContourPoint> contour(const geometry::XrayCamera& camera,
                                    const geometry::Pose& camera_from_mesh,
                                    double spacing_px = 1.0) const;

 private:
  struct Edge {
    int a;
    int b;
    int face_left;
    int face_right;
  };
  geometry::Mesh mesh_;
  std::vector<Edge> edges_;
  std::vector<Eigen::Vector3d> face_normals_;
};

}  // namespace imaging
}  // namespace fluoro_tracker
