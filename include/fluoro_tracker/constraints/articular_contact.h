#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fluoro_tracker/geometry/mesh.h"
#include "fluoro_tracker/geometry/mesh_bvh.h"
#include "fluoro_tracker/geometry/pose.h"
#include "fluoro_tracker/geometry/signed_distance_grid.h"

namespace fluoro_tracker {
namespace constraints {

// What the contact penalty measures (dissertation ch. 3: all from the same per-point signed
// distances). q = penetration beyond the dead band, in mm, over the parent's sampled surface.
enum class ContactMeasure {
  kPenetrationDepth,  // max q (mm)
  kPenetrationArea,   // area where q > 0 (mm^2)
  kQuasiVolume,       // integral of q over the surface (mm^3); ~ the penetrating volume
  kElasticEnergy,     // 1/2 integral of q^2 (mm^4): an elastic foundation of unit modulus
  kSeparation,        // max(0, smallest signed distance - dead band) (mm): a joint that must
                      // stay in contact; the dead band is the gap allowed
};

// YAML names: penetration_depth, penetration_area, quasi_volume, elastic_energy, separation.
ContactMeasure contactMeasureFromName(const std::string& name);  // throws InputError
std::string contactMeasureName(ContactMeasure measure);

// The part of the parent's articular surface that is sampled, in the parent's frame (metres):
// triangles whose centroid lies in the box (when given) and whose outward normal is within
// max_angle_deg of `normal` (when non-zero). E.g. the condyles of a femoral component: normal
// -Y (inferior), 80 deg.
struct ContactRegion {
  Eigen::AlignedBox3d box;  // empty box: no limit
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double max_angle_deg = 90.0;
};

struct ContactSettings {
  bool enabled = true;
  ContactMeasure measure = ContactMeasure::kQuasiVolume;
  // Penetration up to this depth costs nothing (insert creep and wear, cartilage thickness);
  // for kSeparation, the gap allowed.
  double dead_band_mm = 0.0;
  // The residual is weight x measure^exponent (the dissertation used quasi-volume^0.7, which
  // is gentler on deep penetration than the volume itself). With the default, 0.5 mm of
  // penetration over 1 cm^2 costs as much as ~40 contour points 4 px off: contact acts almost
  // as a hard constraint against the image terms.
  double exponent = 0.7;
  double weight = 20.0;
  // When the joint is known to be loaded (e.g. a force plate or instrumented tray reads a
  // compressive force), a stay-in-contact term (the separation measure, exponent 1) with this
  // weight joins for that frame.
  double loaded_weight = 20.0;
  ContactRegion region;
  // The parent's surface is sampled at its vertices and at points this far apart at most on its
  // larger triangles (each split evenly into smaller ones; 0: vertices only). Distances are
  // linear across each (sub-)triangle, so a triangle larger than a feature of the child's
  // surface lets that feature pass through it unseen: a vendor model's flat faces (a
  // posterior-stabilised box wall, a cam) are often a few large triangles, where a post could
  // enter a wall's middle with every vertex outside it. 3 mm leaves a typical articular
  // tessellation (1-3 mm: the generated components' condyles, the Kneel study's femoral
  // component at 2.4-3.0 mm) as it is.
  double max_sample_spacing_mm = 3.0;
  geometry::SignedDistanceGridSettings grid;

  void validate() const;  // throws InputError naming the field
};

// The stay-in-contact term of a joint with contact settings `base`: the separation measure,
// no allowed gap, linear in it, with `weight` (grid and region as in `base`).
ContactSettings stayInContactSettings(const ContactSettings& base, double weight);

// Where the surfaces interpenetrate: a sampled point of the parent's surface and its depth.
struct ContactPoint {
  Eigen::Vector3d position;  // in the frame the poses were given in
  double depth_m = 0.0;      // > 0: inside the child's surface
};

// Penetration figures of one joint at one pair of poses (no dead band unless stated).
struct ContactFigures {
  bool in_collision = false;    // FCL: the surfaces intersect
  double min_distance_m = 0.0;  // FCL when apart (> 0), else minus the deepest penetration
  double max_depth_m = 0.0;
  double area_m2 = 0.0;
  double quasi_volume_m3 = 0.0;
  double measure = 0.0;  // the configured measure (mm units), with the dead band
  double penalty = 0.0;  // weight x measure^exponent: what registration minimises
  std::vector<ContactPoint> points;
};

// Articular contact between a parent's and a child's surface (e.g. femoral component and
// tibial insert): the parent's surface is sampled at its vertices (and inside its triangles
// larger than max_sample_spacing_mm) and integrated over its triangles; the child's closed surface
// is a signed distance grid (built once) that the samples are looked up in; FCL BVHs of both (built
// once) answer collision and separation. The distance along each parent triangle is taken as linear
// between its vertices, so area, quasi-volume and energy are exact integrals of that interpolant:
// continuous in the pose, with derivatives that do not jump when a vertex crosses the surface.
class ArticularContact {
 public:
  // Throws InputError if the child surface is not closed, the region selects no triangle, or
  // the settings are invalid.
  ArticularContact(const geometry::Mesh& parent_surface, const geometry::Mesh& child_surface,
                   const ContactSettings& settings);

  const ContactSettings& settings() const { return settings_; }
  // Sampled points of the parent's surface (its frame, metres).
  const std::vector<Eigen::Vector3d>& samples() const { return samples_; }
  const geometry::SignedDistanceGrid& grid() const { return *grid_; }

  // A part of the sampled surface: some samples (indices into samples()) and the triangles
  // with a corner among them.
  struct SampleSubset {
    std::vector<int> samples;
    std::vector<int> triangles;
  };
  // The subset of `samples` (indices, each at most once).
  SampleSubset subset(std::vector<int> samples) const;

  // The configured measure (mm units) from the signed distances (metres, child surface) of
  // every sample; fills d(measure)/d(distance_i) when asked.
  double measure(const double* distances_m, double* d_measure_d_distance) const;
  // The same where every sample outside `part` lies outside the child surface by more than
  // the dead band (as a caller's culling guarantees): the measure then only needs the part,
  // which is much faster when it is small. d(measure)/d(distance_i) is filled at the part's
  // samples and the corners of its triangles.
  double measure(const double* distances_m, double* d_measure_d_distance,
                 const SampleSubset& part) const;
  // weight x measure^exponent (smoothed at 0 so its derivative stays finite) and its
  // derivative with respect to the measure.
  double penalty(double measure, double* d_penalty_d_measure) const;

  // Figures with the bones at the given poses (any common frame); contact points if asked.
  // sampledFigures() and then addSeparation().
  ContactFigures figures(const geometry::Pose& parent_pose, const geometry::Pose& child_pose,
                         bool with_points = false) const;
  // Every figure but FCL's two (in_collision and min_distance_m stay at their defaults): those
  // from the surface samples alone.
  ContactFigures sampledFigures(const geometry::Pose& parent_pose, const geometry::Pose& child_pose,
                                bool with_points = false) const;
  // FCL's collision test and, when the surfaces are apart, their distance, into figures that
  // sampledFigures() made at the same poses. Three quarters of figures()' time (0.56 of 0.76
  // ms with the simulated femoral component and insert), so a caller that compares many
  // solutions adds it to the one it keeps.
  void addSeparation(const geometry::Pose& parent_pose, const geometry::Pose& child_pose,
                     ContactFigures* figures) const;

 private:
  struct Triangle {
    int sample[3];
    double area_mm2;
  };
  ContactSettings settings_;
  std::vector<Eigen::Vector3d> samples_;
  std::vector<Triangle> triangles_;
  std::shared_ptr<const geometry::SignedDistanceGrid> grid_;
  std::shared_ptr<geometry::MeshBvh> parent_bvh_;
  std::shared_ptr<geometry::MeshBvh> child_bvh_;
};

}  // namespace constraints
}  // namespace fluoro_tracker
