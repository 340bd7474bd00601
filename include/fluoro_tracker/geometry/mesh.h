#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "fluoro_tracker/geometry/length_unit.h"
#include "fluoro_tracker/geometry/pose.h"

namespace fluoro_tracker {
namespace geometry {

// Key of the undirected edge between vertex indices a and b (the same for a-b and b-a), for
// hashing edges while walking triangles.
inline std::uint64_t undirectedEdgeKey(int a, int b) {
  const auto lo = static_cast<std::uint64_t>(static_cast<std::uint32_t>(a < b ? a : b));
  const auto hi = static_cast<std::uint64_t>(static_cast<std::uint32_t>(a < b ? b : a));
  return (lo << 32) | hi;
}

// Edge-based topology summary of a triangle mesh.
struct MeshTopology {
  std::size_t boundary_edges = 0;        // edges used by one triangle only (holes)
  std::size_t non_manifold_edges = 0;    // edges used by three or more triangles
  std::size_t misoriented_edges = 0;     // edges whose two triangles traverse it the same way
  std::size_t degenerate_triangles = 0;  // zero area or repeated vertex indices

  // Closed, two-manifold and consistently oriented: a watertight surface with a well-defined
  // inside, as path-length rendering and penetration measures need.
  bool isClosed() const {
    return boundary_edges == 0 && non_manifold_edges == 0 && misoriented_edges == 0;
  }
  std::string describe() const;
};

struct MeshLoadOptions {
  LengthUnit file_units = LengthUnit::kMillimetre;
  // Reject meshes that are not closed and consistently oriented (renderers and contact
  // measures need an inside). Turn off only for meshes used for display.
  bool require_closed = true;
};

// An indexed triangle mesh in metres. Triangles are counter-clockwise seen from outside, so
// face normals point outward; load() fixes a closed mesh that is consistently oriented inward.
class Mesh {
 public:
  using Triangle = Eigen::Vector3i;

  Mesh() = default;
  // Throws InputError if an index is out of range or a vertex is not finite.
  Mesh(std::vector<Eigen::Vector3d> vertices, std::vector<Triangle> triangles);

  // Loads STL (ascii or binary), OBJ, PLY and the other formats assimp reads; vertices shared
  // between faces are welded. Errors name the file and the problem: missing, empty, corrupt,
  // no triangles, or (with require_closed) not closed.
  static Mesh load(const std::string& path, const MeshLoadOptions& options = {});
  // Writes the mesh with assimp; the format follows the extension: .stl (binary STL), .obj, .ply.
  void save(const std::string& path, LengthUnit file_units = LengthUnit::kMillimetre) const;

  const std::vector<Eigen::Vector3d>& vertices() const { return vertices_; }
  const std::vector<Triangle>& triangles() const { return triangles_; }
  std::size_t vertexCount() const { return vertices_.size(); }
  std::size_t triangleCount() const { return triangles_.size(); }
  bool empty() const { return triangles_.empty(); }

  // Unit outward normal of each triangle (zero for a degenerate one).
  std::vector<Eigen::Vector3d> faceNormals() const;
  // Area-weighted average of adjacent face normals, normalised.
  std::vector<Eigen::Vector3d> vertexNormals() const;
  double surfaceArea() const;
  // Enclosed volume by the divergence theorem; positive for an outward-oriented closed mesh.
  double volume() const;
  // Centre of the enclosed volume (closed meshes) .
  Eigen::Vector3d volumeCentroid() const;
  Eigen::AlignedBox3d bounds() const;
  MeshTopology topology() const;

  Mesh transformed(const Pose& pose) const;
  Mesh scaled(double factor) const;
  // The mirror image across the plane through the origin normal to coordinate `axis` (0, 1, 2),
  // its windings reversed so that normals still point outward: with axis 2 (the ISB frame's
  // medial-lateral Z), a right knee's component as the left one's.
  Mesh mirrored(int axis) const;
  // Reverses every triangle's winding (turns normals inside out).
  void flipOrientation();
  // Adds another mesh's triangles as a separate component.
  void append(const Mesh& other);

 private:
  std::vector<Eigen::Vector3d> vertices_;
  std::vector<Triangle> triangles_;
};

}  // namespace geometry
}  // namespace fluoro_tracker
