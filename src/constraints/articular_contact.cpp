// The only translation unit that runs FCL queries between articular surfaces.
#include "fluoro_tracker/constraints/articular_contact.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>

#include <ceres/jet.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace constraints {
namespace {

constexpr double kMillimetresPerMetre = 1000.0;
// Smooths measure^exponent at 0 (mm units): the derivative stays finite.
constexpr double kPenaltyFloor = 1e-6;

// Integrals over a triangle of area `area` of the positive part of a linear function with
// vertex values q: the area where q > 0, the integral of q and of q^2 there. Closed forms: the
// region is the whole triangle, a corner triangle, or the triangle minus a corner triangle.
template <typename T>
void positivePartIntegrals(double area, const T q[3], T integrals[3]) {
  const int positive = (q[0] > 0.0) + (q[1] > 0.0) + (q[2] > 0.0);
  if (positive == 0) {
    integrals[0] = integrals[1] = integrals[2] = T(0.0);
    return;
  }
  const T full0 = T(area);
  const T full1 = T(area / 3.0) * (q[0] + q[1] + q[2]);
  const T full2 = T(area / 6.0) * (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[0] * q[1] +
                                   q[1] * q[2] + q[2] * q[0]);
  if (positive == 3) {
    integrals[0] = full0;
    integrals[1] = full1;
    integrals[2] = full2;
    return;
  }
  // The corner vertex k is the odd one out; q crosses 0 at fractions tj, tl along its edges.
  int k = 0;
  for (int i = 0; i < 3; ++i) {
    if ((q[i] > 0.0) == (positive == 1)) k = i;
  }
  const T& qk = q[k];
  const T& qj = q[(k + 1) % 3];
  const T& ql = q[(k + 2) % 3];
  const T corner_area = T(area) * (qk / (qk - qj)) * (qk / (qk - ql));
  const T corner1 = corner_area * qk / 3.0;
  const T corner2 = corner_area * qk * qk / 6.0;
  if (positive == 1) {
    integrals[0] = corner_area;
    integrals[1] = corner1;
    integrals[2] = corner2;
  } else {
    integrals[0] = full0 - corner_area;
    integrals[1] = full1 - corner1;
    integrals[2] = full2 - corner2;
  }
}

bool inRegion(const ContactRegion& region, const Eigen::Vector3d& centroid,
              const Eigen::Vector3d& normal) {
  if (!region.box.isEmpty() && !region.box.contains(centroid)) return false;
  if (region.normal.squaredNorm() > 0.0) {
    const double cos_limit = std::cos(region.max_angle_deg * M_PI / 180.0);
    if (normal.dot(region.normal.normalized()) < cos_limit) return false;
  }
  return true;
}

}  // namespace

ContactMeasure contactMeasureFromName(const std::string& name) {
  for (ContactMeasure m : {ContactMeasure::kPenetrationDepth, ContactMeasure::kPenetrationArea,
                           ContactMeasure::kQuasiVolume, ContactMeasure::kElasticEnergy,
                           ContactMeasure::kSeparation}) {
    if (contactMeasureName(m) == name) return m;
  }
  throw InputError("contact measure '" + name +
                   "' is not one of penetration_depth, penetration_area, quasi_volume, "
                   "elastic_energy, separation");
}

std::string contactMeasureName(ContactMeasure measure) {
  switch (measure) {
    case ContactMeasure::kPenetrationDepth:
      return "penetration_depth";
    case ContactMeasure::kPenetrationArea:
      return "penetration_area";
    case ContactMeasure::kQuasiVolume:
      return "quasi_volume";
    case ContactMeasure::kElasticEnergy:
      return "elastic_energy";
    case ContactMeasure::kSeparation:
      return "separation";
  }
  return "unknown";
}

void ContactSettings::validate() const {
  if (!(dead_band_mm >= 0.0)) throw InputError("contact: dead_band_mm must be >= 0");
  if (!(max_sample_spacing_mm >= 0.0) || !std::isfinite(max_sample_spacing_mm)) {
    throw InputError("contact: max_sample_spacing_mm must be >= 0 (0: vertices only)");
  }
  if (!(exponent > 0.0)) throw InputError("contact: exponent must be > 0");
  if (!(weight >= 0.0)) throw InputError("contact: weight must be >= 0");
  if (!(loaded_weight >= 0.0)) throw InputError("contact: loaded_weight must be >= 0");
  if (!(region.max_angle_deg > 0.0 && region.max_angle_deg <= 180.0)) {
    throw InputError("contact: region max_angle_deg must be in (0, 180]");
  }
  grid.validate();
}

ContactSettings stayInContactSettings(const ContactSettings& base, double weight) {
  ContactSettings stay = base;
  stay.measure = ContactMeasure::kSeparation;
  stay.dead_band_mm = 0.0;
  stay.exponent = 1.0;
  stay.weight = weight;
  return stay;
}

ArticularContact::ArticularContact(const geometry::Mesh& parent_surface,
                                   const geometry::Mesh& child_surface,
                                   const ContactSettings& settings)
    : settings_(settings) {
  settings_.validate();
  if (parent_surface.empty()) throw InputError("contact: the parent's surface is empty");
  if (!child_surface.topology().isClosed()) {
    throw InputError("contact: the child's articular surface must be closed (" +
                     child_surface.topology().describe() + ")");
  }
  // Sample the parent's surface: the vertices of the triangles in the region, renumbered, and
  // in a triangle longer than the spacing the points of an even n x n split of it. Points on an
  // edge are shared with the neighbour that splits that edge alike (keyed by the edge and the
  // fraction along it), so a surface split evenly stays one connected sample mesh.
  const auto normals = parent_surface.faceNormals();
  const auto& v = parent_surface.vertices();
  const double spacing_m = settings_.max_sample_spacing_mm / kMillimetresPerMetre;
  std::vector<int> sample_of_vertex(parent_surface.vertexCount(), -1);
  std::map<std::array<int, 4>, int> sample_on_edge;  // {lower vertex, upper, step, steps}
  const auto vertexSample = [&](int vertex) {
    int& s = sample_of_vertex[vertex];
    if (s < 0) {
      s = static_cast<int>(samples_.size());
      samples_.push_back(v[vertex]);
    }
    return s;
  };
  for (std::size_t t = 0; t < parent_surface.triangleCount(); ++t) {
    const auto& tri = parent_surface.triangles()[t];
    const Eigen::Vector3d centroid = (v[tri[0]] + v[tri[1]] + v[tri[2]]) / 3.0;
    if (!inRegion(settings_.region, centroid, normals[t])) continue;
    const double longest = std::max({(v[tri[1]] - v[tri[0]]).norm(), (v[tri[2]] - v[tri[1]]).norm(),
                                     (v[tri[0]] - v[tri[2]]).norm()});
    const int n =
        spacing_m > 0.0 ? std::max(1, static_cast<int>(std::ceil(longest / spacing_m))) : 1;
    // A spacing far below the mesh's own would build millions of samples for nothing.
    if (static_cast<double>(n) * n + static_cast<double>(triangles_.size()) > 5e6) {
      throw InputError("contact: max_sample_spacing_mm (" +
                       std::to_string(settings_.max_sample_spacing_mm) +
                       ") splits the parent's surface into more than 5 million triangles");
    }
    // The sample at barycentric grid point (i, j) of n: v0 + i/n (v1 - v0) + j/n (v2 - v0).
    const auto gridSample = [&](int i, int j) {
      const int k = n - i - j;
      if (i == 0 && j == 0) return vertexSample(tri[0]);
      if (i == n) return vertexSample(tri[1]);
      if (j == n) return vertexSample(tri[2]);
      // On an edge: the two corners and how far along from the lower-numbered one.
      int a = -1;
      int b = -1;
      int step = 0;
      if (j == 0) {
        a = tri[0];
        b = tri[1];
        step = i;
      } else if (k == 0) {
        a = tri[1];
        b = tri[2];
        step = j;
      } else if (i == 0) {
        a = tri[2];
        b = tri[0];
        step = k;
      }
      const Eigen::Vector3d point = v[tri[0]] +
                                    (static_cast<double>(i) / n) * (v[tri[1]] - v[tri[0]]) +
                                    (static_cast<double>(j) / n) * (v[tri[2]] - v[tri[0]]);
      if (a < 0) {
        samples_.push_back(point);
        return static_cast<int>(samples_.size()) - 1;
      }
      if (a > b) {
        std::swap(a, b);
        step = n - step;
      }
      // The fraction in lowest terms, so that neighbours split 2 and 4 times share the middle.
      const int common = std::gcd(step, n);
      const auto [it, added] = sample_on_edge.emplace(
          std::array<int, 4>{a, b, step / common, n / common}, static_cast<int>(samples_.size()));
      if (added) samples_.push_back(point);
      return it->second;
    };
    const double area_mm2 = 0.5 * (v[tri[1]] - v[tri[0]]).cross(v[tri[2]] - v[tri[0]]).norm() *
                            kMillimetresPerMetre * kMillimetresPerMetre / (n * n);
    // The corners first, in the parent's order, as without a split.
    for (int k = 0; k < 3; ++k) vertexSample(tri[k]);
    std::vector<int> row(n + 1), next_row(n + 1);
    for (int j = 0; j <= n; ++j) row[j] = gridSample(0, j);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j + i + 1 <= n; ++j) next_row[j] = gridSample(i + 1, j);
      // Upward triangles (i, j), (i+1, j), (i, j+1) and downward ones (i+1, j), (i+1, j+1),
      // (i, j+1): the parent's winding kept.
      for (int j = 0; j + i + 1 <= n; ++j) {
        triangles_.push_back({{row[j], next_row[j], row[j + 1]}, area_mm2});
        if (j + i + 2 <= n) {
          triangles_.push_back({{next_row[j], next_row[j + 1], row[j + 1]}, area_mm2});
        }
      }
      std::swap(row, next_row);
    }
  }
  if (triangles_.empty()) throw InputError("contact: the region selects no triangle of the parent");
  grid_ = std::make_shared<geometry::SignedDistanceGrid>(child_surface, settings_.grid);
  parent_bvh_ = geometry::buildBvh(parent_surface);
  child_bvh_ = geometry::buildBvh(child_surface);
}

ArticularContact::SampleSubset ArticularContact::subset(std::vector<int> samples) const {
  SampleSubset part;
  std::vector<char> chosen(samples_.size(), 0);
  for (int i : samples) chosen.at(static_cast<std::size_t>(i)) = 1;
  part.samples = std::move(samples);
  for (std::size_t t = 0; t < triangles_.size(); ++t) {
    const int* corner = triangles_[t].sample;
    if (chosen[corner[0]] || chosen[corner[1]] || chosen[corner[2]]) {
      part.triangles.push_back(static_cast<int>(t));
    }
  }
  return part;
}

double ArticularContact::measure(const double* distances_m, double* d_measure_d_distance) const {
  SampleSubset everything;
  everything.samples.resize(samples_.size());
  for (std::size_t i = 0; i < samples_.size(); ++i) everything.samples[i] = static_cast<int>(i);
  everything.triangles.resize(triangles_.size());
  for (std::size_t t = 0; t < triangles_.size(); ++t) everything.triangles[t] = static_cast<int>(t);
  return measure(distances_m, d_measure_d_distance, everything);
}

double ArticularContact::measure(const double* distances_m, double* d_measure_d_distance,
                                 const SampleSubset& part) const {
  if (d_measure_d_distance) {
    for (int i : part.samples) d_measure_d_distance[i] = 0.0;
    for (int t : part.triangles) {
      for (int corner : triangles_[t].sample) d_measure_d_distance[corner] = 0.0;
    }
  }
  const double band = settings_.dead_band_mm;
  switch (settings_.measure) {
    case ContactMeasure::kPenetrationDepth: {
      if (part.samples.empty()) return 0.0;
      int deepest = part.samples.front();
      for (int i : part.samples) {
        if (distances_m[i] < distances_m[deepest]) deepest = i;
      }
      const double q = -distances_m[deepest] * kMillimetresPerMetre - band;
      if (q <= 0.0) return 0.0;
      if (d_measure_d_distance) d_measure_d_distance[deepest] = -kMillimetresPerMetre;
      return q;
    }
    case ContactMeasure::kSeparation: {
      if (part.samples.empty()) return 0.0;
      int nearest = part.samples.front();
      for (int i : part.samples) {
        if (distances_m[i] < distances_m[nearest]) nearest = i;
      }
      const double gap = distances_m[nearest] * kMillimetresPerMetre - band;
      if (gap <= 0.0) return 0.0;
      if (d_measure_d_distance) d_measure_d_distance[nearest] = kMillimetresPerMetre;
      return gap;
    }
    case ContactMeasure::kPenetrationArea:
    case ContactMeasure::kQuasiVolume:
    case ContactMeasure::kElasticEnergy:
      break;
  }
  const int which = settings_.measure == ContactMeasure::kPenetrationArea ? 0
                    : settings_.measure == ContactMeasure::kQuasiVolume   ? 1
                                                                          : 2;
  const double scale = which == 2 ? 0.5 : 1.0;
  using Jet = ceres::Jet<double, 3>;
  double total = 0.0;
  for (int index : part.triangles) {
    const Triangle& t = triangles_[index];
    double q[3];
    for (int k = 0; k < 3; ++k) q[k] = -distances_m[t.sample[k]] * kMillimetresPerMetre - band;
    if (q[0] <= 0.0 && q[1] <= 0.0 && q[2] <= 0.0) continue;
    if (!d_measure_d_distance) {
      double integrals[3];
      positivePartIntegrals(t.area_mm2, q, integrals);
      total += scale * integrals[which];
      continue;
    }
    Jet qj[3];
    for (int k = 0; k < 3; ++k) qj[k] = Jet(q[k], k);
    Jet integrals[3];
    positivePartIntegrals(t.area_mm2, qj, integrals);
    total += scale * integrals[which].a;
    for (int k = 0; k < 3; ++k) {
      d_measure_d_distance[t.sample[k]] -= scale * integrals[which].v[k] * kMillimetresPerMetre;
    }
  }
  return total;
}

double ArticularContact::penalty(double measure, double* d_penalty_d_measure) const {
  const double e = settings_.exponent;
  const double m = std::max(measure, 0.0) + kPenaltyFloor;
  if (d_penalty_d_measure) *d_penalty_d_measure = settings_.weight * e * std::pow(m, e - 1.0);
  return settings_.weight * (std::pow(m, e) - std::pow(kPenaltyFloor, e));
}

ContactFigures ArticularContact::figures(const geometry::Pose& parent_pose,
                                         const geometry::Pose& child_pose, bool with_points) const {
  ContactFigures f = sampledFigures(parent_pose, child_pose, with_points);
  addSeparation(parent_pose, child_pose, &f);
  return f;
}

ContactFigures ArticularContact::sampledFigures(const geometry::Pose& parent_pose,
                                                const geometry::Pose& child_pose,
                                                bool with_points) const {
  ContactFigures f;
  const geometry::Pose child_from_parent = child_pose.inverse() * parent_pose;
  std::vector<double> distances(samples_.size());
  for (std::size_t i = 0; i < samples_.size(); ++i) {
    distances[i] = grid_->distance(child_from_parent * samples_[i]);
  }
  // Raw figures: no dead band.
  for (const Triangle& t : triangles_) {
    double q[3];
    for (int k = 0; k < 3; ++k) q[k] = -distances[t.sample[k]] * kMillimetresPerMetre;
    double integrals[3];
    positivePartIntegrals(t.area_mm2, q, integrals);
    f.area_m2 += integrals[0] * 1e-6;
    f.quasi_volume_m3 += integrals[1] * 1e-9;
  }
  const double deepest = *std::min_element(distances.begin(), distances.end());
  f.max_depth_m = std::max(0.0, -deepest);
  f.measure = measure(distances.data(), nullptr);
  f.penalty = penalty(f.measure, nullptr);
  if (with_points) {
    for (std::size_t i = 0; i < samples_.size(); ++i) {
      if (distances[i] < 0.0) f.points.push_back({parent_pose * samples_[i], -distances[i]});
    }
  }
  return f;
}

void ArticularContact::addSeparation(const geometry::Pose& parent_pose,
                                     const geometry::Pose& child_pose, ContactFigures* f) const {
  const fcl::CollisionObjectd parent(parent_bvh_, parent_pose.linear(), parent_pose.translation());
  const fcl::CollisionObjectd child(child_bvh_, child_pose.linear(), child_pose.translation());
  fcl::CollisionRequestd collision_request;
  fcl::CollisionResultd collision_result;
  fcl::collide(&parent, &child, collision_request, collision_result);
  f->in_collision = collision_result.isCollision();
  if (f->in_collision) {
    f->min_distance_m = -f->max_depth_m;
  } else {
    fcl::DistanceRequestd distance_request;
    fcl::DistanceResultd distance_result;
    fcl::distance(&parent, &child, distance_request, distance_result);
    f->min_distance_m = distance_result.min_distance;
  }
}

}  // namespace constraints
}  // namespace fluoro_tracker
