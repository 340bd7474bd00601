#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/geometry/xray_camera.h"
#include "fluoro_tracker/imaging/implant_blobs.h"

namespace fluoro_tracker {
namespace imaging {

// A mesh's silhouette seen along one direction, reduced to what identifies its shape.
struct ShapeTemplate {
  Eigen::Matrix3d camera_from_mesh;  // the mesh's orientation; the view looks along camera +z
  double area_m2 = 0.0;              // orthographic silhouette area
  Eigen::Vector2d centroid_m;  // silhouette centroid relative to the mesh origin (camera x, y)
  cv::Mat shape;               // normalised silhouette (see normalizedShape)
  // Points spread along the silhouette's boundaries (outer and inner), metres from the mesh
  // origin (camera x, y): what edge matching compares with the image's edges.
  std::vector<Eigen::Vector2d> outline_m;
};

// A template placed on a frame's edges (SilhouetteLibrary::matchEdges): orientation (template
// and roll about the beam), the mesh origin's pixel and the projection scale, and the mean
// truncated distance of the template's outline to the nearest edge (pixels; lower is better).
struct EdgeMatch {
  int template_index = -1;
  double roll_rad = 0.0;
  Eigen::Vector2d origin_px = Eigen::Vector2d::Zero();
  double px_per_m = 0.0;
  double mean_distance_px = 0.0;
};

// A silhouette region matched to a template: the roll about the beam that aligns them, and
// their dissimilarity (0: identical normalised shapes, 1: disjoint).
struct ShapeMatch {
  int template_index = -1;
  double roll_rad = 0.0;
  double dissimilarity = 1.0;
};

// Silhouettes of a mesh over viewing directions spread evenly over the sphere (a Fibonacci
// lattice), each normalised for position and size, so that a region found in a frame can be
// matched to its viewing direction and roll whatever its distance and place in the image: the
// orientation part of a global pose search, with no rendering at search time. Orthographic
// templates: perspective changes a silhouette little at fluoroscopic distances, and the
// registration that follows removes the difference.
class SilhouetteLibrary {
 public:
  static constexpr int kShapeSize = 32;  // normalised shapes are kShapeSize^2 pixels
  // Throws InputError for an empty mesh or a step outside (1, 90) degrees.
  SilhouetteLibrary(const geometry::Mesh& mesh, double direction_step_deg = 15.0);

  const std::vector<ShapeTemplate>& templates() const { return templates_; }

  // The `count` best matches of a region over all templates and rolls (every roll_step_deg),
  // best first, no two closer than min_separation_deg in orientation.
  // `threads`: how many share the rolls out (parallelFor; the same matches as one).
  static constexpr double kShapeMinSeparationDeg = 20.0;
  std::vector<ShapeMatch> match(const ImplantBlob& blob, int count, double roll_step_deg = 10.0,
                                double min_separation_deg = kShapeMinSeparationDeg,
                                int threads = 1) const;

  // Chamfer matching: every template and roll (every roll_step_deg), at each projection scale
  // (pixels per metre at the bone, i.e. focal length / distance) and at mesh-origin positions
  // every position_step_px inside `search`, scored by the mean distance of the outline's
  // points to the nearest edge, each truncated at truncation_px (so that occluded or merged
  // parts of the outline cost a bounded amount). `edge_distance`: CV_32F distances to the
  // nearest edge in pixels, signed or not (e.g. EdgeMap::unsignedDistance; the magnitude counts).
  // Returns the `count` best placements, no two with orientations closer than
  // min_separation_deg and origins closer than min_separation_px. Unlike region matching it
  // needs no region of the implant alone: a bone whose silhouette merges with its neighbour's
  // is still found by the edges of its own outline. `threads`: how many share the templates out
  // (parallelFor; the same placements as one).
  static constexpr double kEdgeMinSeparationDeg = 15.0;
  static constexpr double kEdgeMinSeparationPx = 6.0;
  std::vector<EdgeMatch> matchEdges(const cv::Mat& edge_distance, const cv::Rect& search,
                                    const std::vector<double>& px_per_m, int count,
                                    double roll_step_deg = 15.0, double position_step_px = 3.0,
                                    double truncation_px = 3.0,
                                    double min_separation_deg = kEdgeMinSeparationDeg,
                                    double min_separation_px = kEdgeMinSeparationPx,
                                    int threads = 1) const;

  // The mesh pose, in the optical frame of `camera` (whose pixels edge_distance had), that an
  // edge match implies.
  geometry::Pose cameraFromMesh(const EdgeMatch& match, const geometry::XrayCamera& camera) const;

  // The mesh pose, in the camera's optical frame, that a match implies for the region: the
  // template's orientation rolled by the match and turned toward the ray through the region,
  // at the distance where the template's area projects to the region's.
  geometry::Pose cameraFromMesh(const ShapeMatch& match, const ImplantBlob& blob,
                                const geometry::XrayCamera& camera) const;

  // A mask's shape in kShapeSize^2 float pixels: centred on its centroid, sqrt(area) scaled to
  // a fixed size, and turned by -roll (so a region rolled by `roll` from a template matches it).
  static cv::Mat normalizedShape(const cv::Mat& mask, const Eigen::Vector2d& centroid,
                                 double area_px, double roll_rad);

 private:
  std::vector<ShapeTemplate> templates_;
};

}  // namespace imaging
}  // namespace fluoro_tracker
