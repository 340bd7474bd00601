#include "fluoro_tracker/geometry/signed_distance_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace geometry {
namespace {

// The feature of a triangle that holds the closest point: its face, one of its vertices or
// one of its edges.
enum class Feature { kFace, kVertexA, kVertexB, kVertexC, kEdgeAB, kEdgeBC, kEdgeCA };

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3d closestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                       Feature* feature) {
  const Eigen::Vector3d ab = b - a;
  const Eigen::Vector3d ac = c - a;
  const Eigen::Vector3d ap = p - a;
  const double d1 = ab.dot(ap);
  const double d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) {
    *feature = Feature::kVertexA;
    return a;
  }
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp);
  const double d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) {
    *feature = Feature::kVertexB;
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    *feature = Feature::kEdgeAB;
    return a + (d1 / (d1 - d3)) * ab;
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp);
  const double d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) {
    *feature = Feature::kVertexC;
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    *feature = Feature::kEdgeCA;
    return a + (d2 / (d2 - d6)) * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    *feature = Feature::kEdgeBC;
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const double denominator = 1.0 / (va + vb + vc);
  *feature = Feature::kFace;
  return a + ab * (vb * denominator) + ac * (vc * denominator);
}

// Angle-weighted pseudonormals of every face, vertex and edge: the sign of (p - closest) . n
// for the closest feature's pseudonormal tells inside from outside exactly on a closed mesh.
struct Pseudonormals {
  std::vector<Eigen::Vector3d> face;
  std::vector<Eigen::Vector3d> vertex;
  std::unordered_map<std::uint64_t, Eigen::Vector3d> edge;

  explicit Pseudonormals(const Mesh& mesh)
      : face(mesh.faceNormals()), vertex(mesh.vertexCount(), Eigen::Vector3d::Zero()) {
    const auto& v = mesh.vertices();
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
      const auto& tri = mesh.triangles()[t];
      for (int k = 0; k < 3; ++k) {
        const int i = tri[k];
        const int j = tri[(k + 1) % 3];
        const int l = tri[(k + 2) % 3];
        const Eigen::Vector3d e1 = (v[j] - v[i]).normalized();
        const Eigen::Vector3d e2 = (v[l] - v[i]).normalized();
        const double angle = std::acos(std::clamp(e1.dot(e2), -1.0, 1.0));
        vertex[i] += angle * face[t];
        // Eigen vectors are not zeroed by default construction.
        edge.try_emplace(undirectedEdgeKey(i, j), Eigen::Vector3d::Zero()).first->second += face[t];
      }
    }
  }

  const Eigen::Vector3d& of(const Mesh::Triangle& tri, std::size_t t, Feature feature) const {
    switch (feature) {
      case Feature::kVertexA:
        return vertex[tri[0]];
      case Feature::kVertexB:
        return vertex[tri[1]];
      case Feature::kVertexC:
        return vertex[tri[2]];
      case Feature::kEdgeAB:
        return edge.at(undirectedEdgeKey(tri[0], tri[1]));
      case Feature::kEdgeBC:
        return edge.at(undirectedEdgeKey(tri[1], tri[2]));
      case Feature::kEdgeCA:
        return edge.at(undirectedEdgeKey(tri[2], tri[0]));
      case Feature::kFace:
        break;
    }
    return face[t];
  }
};

}  // namespace

void SignedDistanceGridSettings::validate() const {
  if (!(spacing_m > 0.0)) throw InputError("signed distance grid: spacing_m must be > 0");
  if (!(margin_m >= 0.0)) throw InputError("signed distance grid: margin_m must be >= 0");
  if (!(exact_band_m >= 2.0 * spacing_m)) {
    // A thinner band could leave gaps through which the chamfer pass carries the wrong sign.
    throw InputError("signed distance grid: exact_band_m must be at least twice spacing_m");
  }
}

SignedDistanceGrid::SignedDistanceGrid(const Mesh& mesh, const SignedDistanceGridSettings& settings)
    : spacing_(settings.spacing_m) {
  settings.validate();
  if (mesh.empty()) throw InputError("signed distance grid: the mesh is empty");
  const Eigen::AlignedBox3d bounds = mesh.bounds();
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(settings.margin_m);
  const Eigen::Vector3d origin = bounds.min() - margin;
  const Eigen::Vector3d extent = bounds.max() + margin - origin;
  for (int k = 0; k < 3; ++k) {
    size_[k] = static_cast<int>(std::ceil(extent[k] / spacing_)) + 1;
  }
  const double nodes = static_cast<double>(size_.x()) * size_.y() * size_.z();
  if (nodes > 64.0e6) {
    throw InputError("signed distance grid: " + std::to_string(static_cast<long long>(nodes)) +
                     " nodes; raise spacing_m or lower margin_m");
  }
  box_ = Eigen::AlignedBox3d(origin,
                             origin + spacing_ * (size_ - Eigen::Vector3i::Ones()).cast<double>());

  const std::size_t count = static_cast<std::size_t>(nodes);
  const double unset = std::numeric_limits<double>::infinity();
  std::vector<double> squared(count, unset);
  std::vector<double> signed_distance(count, unset);
  const Pseudonormals normals(mesh);
  const auto& v = mesh.vertices();
  const double band = settings.exact_band_m;
  auto index = [&](int x, int y, int z) {
    return (static_cast<std::size_t>(z) * size_.y() + y) * size_.x() + x;
  };

  // Exact band: each triangle updates the nodes within `band` of its bounding box.
  for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
    const auto& tri = mesh.triangles()[t];
    Eigen::AlignedBox3d tri_box(v[tri[0]]);
    tri_box.extend(v[tri[1]]).extend(v[tri[2]]);
    Eigen::Vector3i lo;
    Eigen::Vector3i hi;
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::max(
          0, static_cast<int>(std::floor((tri_box.min()[k] - band - origin[k]) / spacing_)));
      hi[k] =
          std::min(size_[k] - 1,
                   static_cast<int>(std::ceil((tri_box.max()[k] + band - origin[k]) / spacing_)));
    }
    for (int z = lo.z(); z <= hi.z(); ++z) {
      for (int y = lo.y(); y <= hi.y(); ++y) {
        for (int x = lo.x(); x <= hi.x(); ++x) {
          const Eigen::Vector3d p = origin + spacing_ * Eigen::Vector3d(x, y, z);
          Feature feature;
          const Eigen::Vector3d closest =
              closestPointOnTriangle(p, v[tri[0]], v[tri[1]], v[tri[2]], &feature);
          const double d2 = (p - closest).squaredNorm();
          const std::size_t i = index(x, y, z);
          if (d2 < squared[i]) {
            squared[i] = d2;
            const double side = (p - closest).dot(normals.of(tri, t, feature));
            signed_distance[i] = side < 0.0 ? -std::sqrt(d2) : std::sqrt(d2);
          }
        }
      }
    }
  }
  std::vector<bool> fixed(count);
  for (std::size_t i = 0; i < count; ++i) {
    fixed[i] = std::abs(signed_distance[i]) <= band;
    if (!fixed[i]) signed_distance[i] = unset;
  }

  // Chamfer propagation beyond the band: a forward and a backward raster pass over the 26
  // neighbours with Euclidean step lengths; each node takes the sign of the neighbour it
  // was reached from.
  struct Step {
    int dx, dy, dz;
    double length;
  };
  std::vector<Step> backward_steps;  // neighbours visited before a node in raster order
  for (int dz = -1; dz <= 0; ++dz) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (dz == 0 && (dy > 0 || (dy == 0 && dx >= 0))) continue;
        backward_steps.push_back(
            {dx, dy, dz, spacing_ * std::sqrt(double(dx * dx + dy * dy + dz * dz))});
      }
    }
  }
  auto relax = [&](int x, int y, int z, int sign) {
    const std::size_t i = index(x, y, z);
    if (fixed[i]) return;
    double best = std::abs(signed_distance[i]);
    double value = signed_distance[i];
    for (const Step& s : backward_steps) {
      const int nx = x + sign * s.dx;
      const int ny = y + sign * s.dy;
      const int nz = z + sign * s.dz;
      if (nx < 0 || ny < 0 || nz < 0 || nx >= size_.x() || ny >= size_.y() || nz >= size_.z())
        continue;
      const double neighbour = signed_distance[index(nx, ny, nz)];
      const double candidate = std::abs(neighbour) + s.length;
      if (candidate < best) {
        best = candidate;
        value = neighbour < 0.0 ? -candidate : candidate;
      }
    }
    signed_distance[i] = value;
  };
  for (int z = 0; z < size_.z(); ++z)
    for (int y = 0; y < size_.y(); ++y)
      for (int x = 0; x < size_.x(); ++x) relax(x, y, z, 1);
  for (int z = size_.z() - 1; z >= 0; --z)
    for (int y = size_.y() - 1; y >= 0; --y)
      for (int x = size_.x() - 1; x >= 0; --x) relax(x, y, z, -1);

  values_.resize(count);
  for (std::size_t i = 0; i < count; ++i) values_[i] = static_cast<float>(signed_distance[i]);
  // Outside the box distance() interpolates between nodes of the two outermost layers (its
  // clamped point lies on a face) and adds the gap: never less than their smallest value.
  const auto outer = [&](int i, int n) { return i <= 1 || i >= n - 2; };
  outside_lower_bound_ = std::numeric_limits<double>::infinity();
  for (int z = 0; z < size_.z(); ++z) {
    for (int y = 0; y < size_.y(); ++y) {
      for (int x = 0; x < size_.x(); ++x) {
        if (outer(x, size_.x()) || outer(y, size_.y()) || outer(z, size_.z())) {
          outside_lower_bound_ = std::min(outside_lower_bound_, node(x, y, z));
        }
      }
    }
  }
}

double SignedDistanceGrid::interpolate(const Eigen::Vector3d& p, Eigen::Vector3d* gradient) const {
  const Eigen::Vector3d g = (p - box_.min()) / spacing_;
  int i[3];
  double f[3];
  for (int k = 0; k < 3; ++k) {
    i[k] = std::clamp(static_cast<int>(std::floor(g[k])), 0, size_[k] - 2);
    f[k] = std::clamp(g[k] - i[k], 0.0, 1.0);
  }
  const double c000 = node(i[0], i[1], i[2]);
  const double c100 = node(i[0] + 1, i[1], i[2]);
  const double c010 = node(i[0], i[1] + 1, i[2]);
  const double c110 = node(i[0] + 1, i[1] + 1, i[2]);
  const double c001 = node(i[0], i[1], i[2] + 1);
  const double c101 = node(i[0] + 1, i[1], i[2] + 1);
  const double c011 = node(i[0], i[1] + 1, i[2] + 1);
  const double c111 = node(i[0] + 1, i[1] + 1, i[2] + 1);
  const double c00 = c000 + f[0] * (c100 - c000);
  const double c10 = c010 + f[0] * (c110 - c010);
  const double c01 = c001 + f[0] * (c101 - c001);
  const double c11 = c011 + f[0] * (c111 - c011);
  const double c0 = c00 + f[1] * (c10 - c00);
  const double c1 = c01 + f[1] * (c11 - c01);
  if (gradient) {
    const double dx0 = (c100 - c000) + f[1] * ((c110 - c010) - (c100 - c000));
    const double dx1 = (c101 - c001) + f[1] * ((c111 - c011) - (c101 - c001));
    (*gradient)[0] = (dx0 + f[2] * (dx1 - dx0)) / spacing_;
    (*gradient)[1] = ((c10 - c00) + f[2] * ((c11 - c01) - (c10 - c00))) / spacing_;
    (*gradient)[2] = (c1 - c0) / spacing_;
  }
  return c0 + f[2] * (c1 - c0);
}

double SignedDistanceGrid::distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient) const {
  if (box_.contains(p)) return interpolate(p, gradient);
  const Eigen::Vector3d clamped = p.cwiseMax(box_.min()).cwiseMin(box_.max());
  const Eigen::Vector3d away = p - clamped;
  const double gap = away.norm();
  const double value = interpolate(clamped, gradient) + gap;
  if (gradient && gap > 0.0) *gradient = (*gradient + away / gap).normalized();
  return value;
}

}  // namespace geometry
}  // namespace fluoro_tracker
