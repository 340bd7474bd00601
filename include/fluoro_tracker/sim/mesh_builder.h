#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "fluoro_tracker/geometry/mesh.h"

namespace fluoro_tracker {
namespace sim {

// Closed-mesh primitives for synthetic models. Every function returns a closed, outward-oriented
// mesh (lengths in whatever unit the arguments use).

// Makes triangle windings agree across shared edges (breadth-first over each connected
// component) and turns each closed component outward (positive volume).
void orientOutward(geometry::Mesh* mesh);

// A prism over a star-shaped outline (about the origin) in the x-z plane, from y = y_bottom to
// y = y_top + top_offset(x, z). The top cap is made of `rings` concentric rings so that a
// curved top_offset is resolved.
geometry::Mesh extrudeOutline(const std::vector<Eigen::Vector2d>& outline_xz, double y_bottom,
                              double y_top, int rings = 1,
                              const std::function<double(double, double)>& top_offset = {});

// Outline points (x, z) of a radial function r(theta), theta from the +x axis toward +z.
std::vector<Eigen::Vector2d> radialOutline(const std::function<double(double)>& radius, int points);

geometry::Mesh cylinderY(double radius_x, double radius_z, double y_bottom, double y_top,
                         int segments = 48);
geometry::Mesh box(const Eigen::Vector3d& half_extents);
geometry::Mesh uvSphere(double radius, int rings = 48, int segments = 96);

// Closed parts built to touch along shared faces (e.g. solids swept over adjoining stations and
// columns) made one closed surface: vertices at identical positions are welded and each pair of
// coincident, oppositely wound triangles (a face two parts share) is removed, with the vertices
// left unused.
geometry::Mesh fuseTouchingFaces(const geometry::Mesh& mesh);

// One station of a swept solid: a point on the sweep path with the in-plane direction along
// which the profile's offsets are measured and the direction along which its columns lie.
struct SweepStation {
  Eigen::Vector3d origin;
  Eigen::Vector3d offset_direction;  // unit
  Eigen::Vector3d column_direction;  // unit, perpendicular to offset_direction
};

// A solid swept through stations: at station i, column c at position columns[c] along the
// column direction spans offsets inner(i, c) .. outer(i, c) along the offset direction
// (outer > inner). The two end stations are capped.
geometry::Mesh sweepProfile(const std::vector<SweepStation>& stations,
                            const std::vector<double>& columns,
                            const std::function<double(int, double)>& inner,
                            const std::function<double(int, double)>& outer);

}  // namespace sim
}  // namespace fluoro_tracker
