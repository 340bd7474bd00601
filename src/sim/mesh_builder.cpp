#include "fluoro_tracker/sim/mesh_builder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <map>
#include <unordered_map>

namespace fluoro_tracker {
namespace sim {
namespace {

using geometry::Mesh;
using Tri = Mesh::Triangle;

// Signed volume of the triangles listed.
double componentVolume(const std::vector<Eigen::Vector3d>& v, const std::vector<Tri>& t,
                       const std::vector<int>& members) {
  double six = 0.0;
  for (int i : members) six += v[t[i][0]].dot(v[t[i][1]].cross(v[t[i][2]]));
  return six / 6.0;
}

}  // namespace

void orientOutward(Mesh* mesh) {
  std::vector<Tri> triangles = mesh->triangles();
  const auto& vertices = mesh->vertices();
  std::unordered_map<std::uint64_t, std::vector<int>> edge_triangles;
  for (int i = 0; i < static_cast<int>(triangles.size()); ++i) {
    for (int k = 0; k < 3; ++k)
      edge_triangles[geometry::undirectedEdgeKey(triangles[i][k], triangles[i][(k + 1) % 3])]
          .push_back(i);
  }
  const auto hasDirectedEdge = [](const Tri& t, int a, int b) {
    for (int k = 0; k < 3; ++k) {
      if (t[k] == a && t[(k + 1) % 3] == b) return true;
    }
    return false;
  };
  std::vector<bool> visited(triangles.size(), false);
  for (int seed = 0; seed < static_cast<int>(triangles.size()); ++seed) {
    if (visited[seed]) continue;
    std::vector<int> component;
    std::deque<int> queue{seed};
    visited[seed] = true;
    while (!queue.empty()) {
      const int i = queue.front();
      queue.pop_front();
      component.push_back(i);
      for (int k = 0; k < 3; ++k) {
        const int a = triangles[i][k];
        const int b = triangles[i][(k + 1) % 3];
        for (int j : edge_triangles[geometry::undirectedEdgeKey(a, b)]) {
          if (visited[j]) continue;
          // A consistently wound neighbour traverses the shared edge as b -> a.
          if (hasDirectedEdge(triangles[j], a, b)) std::swap(triangles[j][1], triangles[j][2]);
          visited[j] = true;
          queue.push_back(j);
        }
      }
    }
    if (componentVolume(vertices, triangles, component) < 0.0) {
      for (int i : component) std::swap(triangles[i][1], triangles[i][2]);
    }
  }
  *mesh = Mesh(vertices, std::move(triangles));
}

std::vector<Eigen::Vector2d> radialOutline(const std::function<double(double)>& radius,
                                           int points) {
  std::vector<Eigen::Vector2d> outline;
  outline.reserve(points);
  for (int j = 0; j < points; ++j) {
    const double theta = 2.0 * M_PI * j / points;
    const double r = radius(theta);
    outline.emplace_back(r * std::cos(theta), r * std::sin(theta));
  }
  return outline;
}

Mesh extrudeOutline(const std::vector<Eigen::Vector2d>& outline, double y_bottom, double y_top,
                    int rings, const std::function<double(double, double)>& top_offset) {
  const int m = static_cast<int>(outline.size());
  rings = std::max(1, rings);
  std::vector<Eigen::Vector3d> v;
  std::vector<Tri> t;
  // Top cap: centre vertex, then rings scaled k/rings toward the outline.
  const auto top_y = [&](double x, double z) {
    return y_top + (top_offset ? top_offset(x, z) : 0.0);
  };
  const int top_centre = 0;
  v.emplace_back(0.0, top_y(0.0, 0.0), 0.0);
  const auto top_index = [&](int ring, int j) { return 1 + (ring - 1) * m + (j % m); };
  for (int ring = 1; ring <= rings; ++ring) {
    const double s = static_cast<double>(ring) / rings;
    for (int j = 0; j < m; ++j) {
      const double x = s * outline[j].x();
      const double z = s * outline[j].y();
      v.emplace_back(x, top_y(x, z), z);
    }
  }
  const int bottom_centre = static_cast<int>(v.size());
  v.emplace_back(0.0, y_bottom, 0.0);
  const int bottom_start = static_cast<int>(v.size());
  for (int j = 0; j < m; ++j) v.emplace_back(outline[j].x(), y_bottom, outline[j].y());
  const auto bottom_index = [&](int j) { return bottom_start + (j % m); };

  for (int j = 0; j < m; ++j) {
    t.emplace_back(top_centre, top_index(1, j + 1), top_index(1, j));
    for (int ring = 1; ring < rings; ++ring) {
      t.emplace_back(top_index(ring, j), top_index(ring, j + 1), top_index(ring + 1, j + 1));
      t.emplace_back(top_index(ring, j), top_index(ring + 1, j + 1), top_index(ring + 1, j));
    }
    t.emplace_back(bottom_centre, bottom_index(j), bottom_index(j + 1));
    t.emplace_back(top_index(rings, j), bottom_index(j + 1), bottom_index(j));
    t.emplace_back(top_index(rings, j), top_index(rings, j + 1), bottom_index(j + 1));
  }
  Mesh mesh(std::move(v), std::move(t));
  orientOutward(&mesh);
  return mesh;
}

Mesh cylinderY(double radius_x, double radius_z, double y_bottom, double y_top, int segments) {
  std::vector<Eigen::Vector2d> outline;
  for (int j = 0; j < segments; ++j) {
    const double a = 2.0 * M_PI * j / segments;
    outline.emplace_back(radius_x * std::cos(a), radius_z * std::sin(a));
  }
  return extrudeOutline(outline, y_bottom, y_top);
}

Mesh box(const Eigen::Vector3d& h) {
  std::vector<Eigen::Vector3d> v;
  for (int i = 0; i < 8; ++i) {
    v.emplace_back((i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(), (i & 4) ? h.z() : -h.z());
  }
  // Two triangles per face; orientOutward fixes the windings.
  std::vector<Tri> t = {{0, 1, 3}, {0, 3, 2}, {4, 6, 7}, {4, 7, 5}, {0, 4, 5}, {0, 5, 1},
                        {2, 3, 7}, {2, 7, 6}, {0, 2, 6}, {0, 6, 4}, {1, 5, 7}, {1, 7, 3}};
  Mesh mesh(std::move(v), std::move(t));
  orientOutward(&mesh);
  return mesh;
}

Mesh uvSphere(double radius, int rings, int segments) {
  std::vector<Eigen::Vector3d> v;
  std::vector<Tri> t;
  v.emplace_back(0.0, 0.0, radius);  // north pole
  for (int r = 1; r < rings; ++r) {
    const double polar = M_PI * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double azimuth = 2.0 * M_PI * s / segments;
      v.emplace_back(radius * std::sin(polar) * std::cos(azimuth),
                     radius * std::sin(polar) * std::sin(azimuth), radius * std::cos(polar));
    }
  }
  const int south = static_cast<int>(v.size());
  v.emplace_back(0.0, 0.0, -radius);
  const auto index = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
  for (int s = 0; s < segments; ++s) {
    t.emplace_back(0, index(1, s), index(1, s + 1));
    for (int r = 1; r < rings - 1; ++r) {
      t.emplace_back(index(r, s), index(r + 1, s), index(r + 1, s + 1));
      t.emplace_back(index(r, s), index(r + 1, s + 1), index(r, s + 1));
    }
    t.emplace_back(south, index(rings - 1, s + 1), index(rings - 1, s));
  }
  Mesh mesh(std::move(v), std::move(t));
  orientOutward(&mesh);
  return mesh;
}

Mesh fuseTouchingFaces(const Mesh& mesh) {
  std::map<std::array<double, 3>, int> welded;
  std::vector<int> to_welded(mesh.vertexCount());
  std::vector<Eigen::Vector3d> positions;
  for (std::size_t i = 0; i < mesh.vertexCount(); ++i) {
    const Eigen::Vector3d& p = mesh.vertices()[i];
    const auto [it, added] = welded.emplace(std::array<double, 3>{p.x(), p.y(), p.z()},
                                            static_cast<int>(positions.size()));
    if (added) positions.push_back(p);
    to_welded[i] = it->second;
  }
  std::vector<Tri> triangles;
  for (const Tri& t : mesh.triangles())
    triangles.emplace_back(to_welded[t[0]], to_welded[t[1]], to_welded[t[2]]);
  // Triangles by their vertex set: a shared face appears twice, wound both ways.
  std::map<std::array<int, 3>, std::vector<int>> by_corners;
  for (int i = 0; i < static_cast<int>(triangles.size()); ++i) {
    std::array<int, 3> corners{triangles[i][0], triangles[i][1], triangles[i][2]};
    std::sort(corners.begin(), corners.end());
    by_corners[corners].push_back(i);
  }
  std::vector<bool> shared(triangles.size(), false);
  for (const auto& [corners, members] : by_corners) {
    if (members.size() != 2) continue;
    const Tri& a = triangles[members[0]];
    const Tri& b = triangles[members[1]];
    // Opposite windings: b traverses a's first edge backwards.
    bool opposite = false;
    for (int k = 0; k < 3; ++k) opposite = opposite || (b[k] == a[1] && b[(k + 1) % 3] == a[0]);
    if (opposite) shared[members[0]] = shared[members[1]] = true;
  }
  std::vector<int> compact(positions.size(), -1);
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Tri> kept;
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    if (shared[i]) continue;
    Tri t = triangles[i];
    for (int k = 0; k < 3; ++k) {
      int& c = compact[t[k]];
      if (c < 0) {
        c = static_cast<int>(vertices.size());
        vertices.push_back(positions[t[k]]);
      }
      t[k] = c;
    }
    kept.push_back(t);
  }
  return Mesh(std::move(vertices), std::move(kept));
}

Mesh sweepProfile(const std::vector<SweepStation>& stations, const std::vector<double>& columns,
                  const std::function<double(int, double)>& inner,
                  const std::function<double(int, double)>& outer) {
  const int n_stations = static_cast<int>(stations.size());
  const int n_columns = static_cast<int>(columns.size());
  const int ring = 2 * n_columns;  // inner columns left to right, then outer right to left
  std::vector<Eigen::Vector3d> v;
  std::vector<Tri> t;
  for (int i = 0; i < n_stations; ++i) {
    const SweepStation& st = stations[i];
    for (int c = 0; c < n_columns; ++c) {
      v.push_back(st.origin + inner(i, columns[c]) * st.offset_direction +
                  columns[c] * st.column_direction);
    }
    for (int c = n_columns - 1; c >= 0; --c) {
      v.push_back(st.origin + outer(i, columns[c]) * st.offset_direction +
                  columns[c] * st.column_direction);
    }
  }
  const auto index = [&](int i, int k) { return i * ring + (k % ring); };
  for (int i = 0; i + 1 < n_stations; ++i) {
    for (int k = 0; k < ring; ++k) {
      t.emplace_back(index(i, k), index(i, k + 1), index(i + 1, k + 1));
      t.emplace_back(index(i, k), index(i + 1, k + 1), index(i + 1, k));
    }
  }
  // End caps: a strip of quads between each inner column and its outer partner.
  for (int i : {0, n_stations - 1}) {
    for (int c = 0; c + 1 < n_columns; ++c) {
      const int in0 = index(i, c);
      const int in1 = index(i, c + 1);
      const int out0 = index(i, ring - 1 - c);
      const int out1 = index(i, ring - 2 - c);
      t.emplace_back(in0, in1, out1);
      t.emplace_back(in0, out1, out0);
    }
  }
  Mesh mesh(std::move(v), std::move(t));
  orientOutward(&mesh);
  return mesh;
}

}  // namespace sim
}  // namespace fluoro_tracker
