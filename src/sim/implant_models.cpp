#include "fluoro_tracker/sim/implant_models.h"

#include <algorithm>
#include <cmath>

#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/sim/mesh_builder.h"

namespace fluoro_tracker {
namespace sim {
namespace {

using geometry::Mesh;

constexpr double kDeg = M_PI / 180.0;

// Everything below is built in millimetres and scaled to metres at the end.

// Tray/insert outline: an ellipse with a posterior cruciate notch (theta from +x = anterior
// toward +z = lateral; the notch is at theta = pi, posterior).
double trayRadius(const KneeImplantDimensions& d, double theta, double shrink) {
  const double a = 0.5 * d.tray_ap_mm * shrink;
  const double b = 0.5 * d.tray_ml_mm * shrink;
  const double c = std::cos(theta);
  const double s = std::sin(theta);
  const double ellipse = a * b / std::sqrt(b * b * c * c + a * a * s * s);
  double wrapped = std::remainder(theta - M_PI, 2.0 * M_PI);
  return ellipse * (1.0 - 0.22 * std::exp(-(wrapped * wrapped) / (2.0 * 0.18 * 0.18)));
}

constexpr double kInsertShrink = 0.97;

double dishOffsetMm(const KneeImplantDimensions& d, double x, double z) {
  // Two condylar tracks, slightly posterior. Medial-lateral width 10 mm: with a 3 mm depth the
  // bottom's coronal radius is 33 mm, a little larger than the condyles' (30 mm), so each condyle
  // sits in its track as on a real insert, and sliding medial-lateral climbs a track's wall.
  // Toward the midline the wall rises only to the central eminence, which stays below the
  // femoral component's intercondylar region (real components have an open notch there), so
  // the condyles, not the eminence, carry the load.
  const double dx = x + 2.0;
  const double along = std::exp(-(dx * dx) / (2.0 * 13.0 * 13.0));
  double offset = 0.0;
  for (double zc : {-d.condyle_track_mm, d.condyle_track_mm}) {
    // The lateral (+z) track is shallower by as much as the lateral condyle is smaller, so
    // that both condyles bear load in neutral alignment.
    const double bottom =
        std::max(0.0, d.dish_depth_mm - (zc > 0.0 ? d.lateral_condyle_offset_mm : 0.0));
    const double eminence = std::clamp(d.eminence_height_mm, 0.0, bottom);
    const double dz = z - zc;
    const double across = std::exp(-(dz * dz) / (2.0 * 10.0 * 10.0));
    const bool toward_midline = dz * zc < 0.0;
    const double depth = toward_midline ? bottom - eminence * (1.0 - across) : bottom * across;
    offset = std::min(offset, -depth * along);
  }
  return offset;
}

// Inner (bone-facing) surface of the femoral component: distance from the flexion axis to the
// box cuts along the direction (cos phi, -sin phi) in the sagittal plane.
double boxCutDistance(double phi) {
  const Eigen::Vector2d direction(std::cos(phi), -std::sin(phi));
  struct Cut {
    Eigen::Vector2d normal;
    double distance;
  };
  const double r2 = std::sqrt(0.5);
  const Cut cuts[] = {
      {{1.0, 0.0}, 17.0},   // anterior
      {{r2, -r2}, 18.5},    // anterior chamfer
      {{0.0, -1.0}, 18.0},  // distal
      {{-r2, -r2}, 18.5},   // posterior chamfer (deep enough for the condyles' coronal
                            // rounding to keep 1.5 mm of metal at the chamfer corners)
      {{-1.0, 0.0}, 16.0},  // posterior
      {{0.0, 1.0}, 60.0},   // top of the box (never reached by the component)
  };
  double best = 1e9;
  for (const Cut& cut : cuts) {
    const double along = cut.normal.dot(direction);
    if (along > 1e-9) best = std::min(best, cut.distance / along);
  }
  return best;
}

Mesh makeFemoralComponent(const KneeImplantDimensions& d) {
  const double half_width = 0.5 * d.width_mm;
  const double flange_height = 36.0;
  const double phi_end = 212.0 * kDeg;  // posterior condyles end where they meet the posterior cut

  // Sweep path: the anterior flange straight down to the flexion axis level, then around the
  // condyles from anterior (phi = 0) through distal (90 deg) to posterior (180 deg) and beyond.
  struct PathPoint {
    double phi;     // <0 marks flange stations
    double height;  // flange station height above the axis
  };
  std::vector<PathPoint> path;
  const int flange_stations = 9;
  for (int i = 0; i < flange_stations; ++i) {
    path.push_back({-1.0, flange_height * (1.0 - static_cast<double>(i) / flange_stations)});
  }
  const int arc_stations = 96;
  for (int i = 0; i <= arc_stations; ++i) path.push_back({phi_end * i / arc_stations, 0.0});

  const auto articularRadius = [&](double phi) {
    // Distal/anterior radius blends to the smaller posterior radius between 100 and 160 deg.
    const double blend = std::clamp((phi / kDeg - 100.0) / 60.0, 0.0, 1.0);
    const double smooth = blend * blend * (3.0 - 2.0 * blend);
    return d.distal_radius_mm + (d.posterior_radius_mm - d.distal_radius_mm) * smooth;
  };
  const auto outerRadius = [&](double phi, double z) {
    const double phi_deg = phi / kDeg;
    double r = articularRadius(phi);
    // Lateral (+z) condyle slightly smaller on the distal and posterior surfaces.
    const double lateral = 0.5 * (1.0 + std::tanh(z / 4.0));
    r -= d.lateral_condyle_offset_mm * lateral * std::clamp((phi_deg - 40.0) / 40.0, 0.0, 1.0);
    // Trochlear groove anteriorly, deepening into the intercondylar notch posteriorly.
    const double groove_depth = 2.5 + 4.0 * std::clamp((phi_deg - 90.0) / 60.0, 0.0, 1.0);
    const double groove_width = 6.0 + 3.0 * std::clamp((phi_deg - 90.0) / 60.0, 0.0, 1.0);
    r -= groove_depth * std::exp(-(z * z) / (2.0 * groove_width * groove_width));
    // Each condyle is rounded in the coronal plane (a torus about its track), as on real
    // components; 0 leaves the condyles flat across.
    if (d.condyle_coronal_radius_mm > 0.0) {
      const double from_track = std::abs(z) - d.condyle_track_mm;
      r -= from_track * from_track / (2.0 * d.condyle_coronal_radius_mm);
    }
    // Rounded medial and lateral edges.
    r -= 3.0 * std::pow(std::abs(z) / half_width, 8.0);
    // Never thinner than 1.5 mm.
    return std::max(r, boxCutDistance(phi) + 1.5);
  };
  // The solid swept along part of the path over these columns.
  const auto sweep = [&](const std::vector<PathPoint>& part, const std::vector<double>& columns) {
    std::vector<SweepStation> stations;
    std::vector<double> station_phi;
    for (const PathPoint& p : part) {
      const double phi = std::max(p.phi, 0.0);
      const Eigen::Vector3d direction(std::cos(phi), -std::sin(phi), 0.0);
      stations.push_back(
          {Eigen::Vector3d(0.0, p.height, 0.0), direction, Eigen::Vector3d::UnitZ()});
      station_phi.push_back(phi);
    }
    return sweepProfile(
        stations, columns, [&](int i, double) { return boxCutDistance(station_phi[i]); },
        [&](int i, double z) { return outerRadius(station_phi[i], z); });
  };

  std::vector<double> columns;
  const int n_columns = 29;
  for (int c = 0; c < n_columns; ++c)
    columns.push_back(-half_width + d.width_mm * c / (n_columns - 1));
  if (!d.posteriorStabilised()) return sweep(path, columns);

  // Posterior-stabilised: the full width up to the box's opening, then each condyle alone. The
  // three solids share the opening's station over the condyles' columns and the box's walls
  // fall on columns of all three, so that fused along those faces they are one closed surface,
  // as a vendor's model would be.
  const double box_half = 0.5 * d.box_width_mm;
  for (double wall : {-box_half, box_half}) {
    const bool present = std::any_of(columns.begin(), columns.end(),
                                     [&](double c) { return std::abs(c - wall) < 1e-9; });
    if (!present) columns.push_back(wall);
  }
  std::sort(columns.begin(), columns.end());
  const double phi_open = kBoxStartDeg * kDeg;
  std::vector<PathPoint> anterior;
  std::vector<PathPoint> condyles;
  for (const PathPoint& p : path) {
    if (p.phi < phi_open - 1e-9) anterior.push_back(p);
  }
  anterior.push_back({phi_open, 0.0});
  condyles.push_back({phi_open, 0.0});
  for (const PathPoint& p : path) {
    if (p.phi > phi_open + 1e-9) condyles.push_back(p);
  }
  std::vector<double> medial;
  std::vector<double> lateral;
  for (double c : columns) {
    if (c <= -box_half + 1e-9) medial.push_back(c);
    if (c >= box_half - 1e-9) lateral.push_back(c);
  }
  Mesh component = sweep(anterior, columns);
  component.append(sweep(condyles, medial));
  component.append(sweep(condyles, lateral));
  return fuseTouchingFaces(component);
}

}  // namespace

double insertSurfaceHeight(const KneeImplantDimensions& d, double x, double z) {
  return 1e-3 * (d.insert_thickness_mm + dishOffsetMm(d, 1e3 * x, 1e3 * z));
}

bool isOverInsert(const KneeImplantDimensions& d, double x, double z) {
  const double theta = std::atan2(z, x);
  return std::hypot(x, z) * 1e3 <= trayRadius(d, theta, kInsertShrink);
}

void KneeImplantDimensions::validate() const {
  if (!(condyle_track_mm > 0.0) || !(condyle_track_mm < 0.5 * width_mm)) {
    throw InputError("implants: condyle_track_mm must lie between 0 and half width_mm");
  }
  if (!(box_width_mm >= 0.0)) throw InputError("implants: box_width_mm must be >= 0");
  if (!posteriorStabilised()) return;
  if (!(box_width_mm < 2.0 * condyle_track_mm)) {
    throw InputError(
        "implants: box_width_mm must leave the condyles' tracks (2 x condyle_track_mm)");
  }
  if (!(post_width_mm > 0.0 && post_width_mm < box_width_mm)) {
    throw InputError("implants: post_width_mm must be > 0 and less than box_width_mm");
  }
  if (!(post_length_mm > 0.0) ||
      !(std::abs(post_offset_mm) + 0.5 * post_length_mm < 0.5 * kInsertShrink * tray_ap_mm)) {
    throw InputError(
        "implants: post_length_mm must be > 0, and the post (post_offset_mm) on the insert");
  }
  if (!(post_height_mm > 0.0)) throw InputError("implants: post_height_mm must be > 0");
  // The post stands clear of the dished surface under its footprint.
  for (int i = 0; i <= 20; ++i) {
    for (int j = 0; j <= 20; ++j) {
      const double u = i / 10.0 - 1.0;
      const double v = j / 10.0 - 1.0;
      if (u * u + v * v > 1.0) continue;
      const double x = post_offset_mm + 0.5 * post_length_mm * u;
      const double z = 0.5 * post_width_mm * v;
      if (dishOffsetMm(*this, x, z) > -0.1) {
        throw InputError(
            "implants: the post's footprint (post_length_mm x post_width_mm) reaches the "
            "insert's rim height; it must stand over the dished region (dish_depth_mm)");
      }
    }
  }
}

KneeImplantSet makeKneeImplants(const KneeImplantDimensions& d) {
  d.validate();
  KneeImplantSet set;
  set.femoral_component = makeFemoralComponent(d).scaled(1e-3);

  const int outline_points = 96;
  const auto tray_outline =
      radialOutline([&](double theta) { return trayRadius(d, theta, 1.0); }, outline_points);
  Mesh tray = extrudeOutline(tray_outline, -4.0, 0.0);
  // Stem: a separate closed component touching the plate's underside, so path lengths through
  // the tray stay exact (the shared plane's exit and entry cancel).
  tray.append(extrudeOutline(radialOutline([](double) { return 7.0; }, 40), -40.0, -4.0));
  set.tibial_tray = tray.scaled(1e-3);

  const auto insert_outline = radialOutline(
      [&](double theta) { return trayRadius(d, theta, kInsertShrink); }, outline_points);
  Mesh insert = extrudeOutline(insert_outline, 0.0, d.insert_thickness_mm, 14,
                               [&](double x, double z) { return dishOffsetMm(d, x, z); });
  if (d.posteriorStabilised()) {
    // A separate closed body standing at the rim's height, clear of the dished surface below it
    // (validate()), so that the insert's signed distance, which takes its sign from the nearest
    // surface's orientation, stays exact: touching or overlapping bodies would confuse it.
    Mesh post = cylinderY(0.5 * d.post_length_mm, 0.5 * d.post_width_mm, d.insert_thickness_mm,
                          d.insert_thickness_mm + d.post_height_mm);
    insert.append(post.transformed(
        geometry::makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(d.post_offset_mm, 0, 0))));
  }
  set.tibial_insert = insert.scaled(1e-3);
  return set;
}

KneeImplantSet makeKneeImplants(const KneeImplantDimensions& d, const ImplantMeshFiles& files) {
  KneeImplantSet set = makeKneeImplants(d);
  geometry::MeshLoadOptions options;
  options.file_units = files.units;
  const auto load = [&](const ImplantMeshFile& file, Mesh* mesh) {
    if (file.path.empty()) return false;
    *mesh = Mesh::load(file.path, options).transformed(file.component_from_mesh);
    return true;
  };
  load(files.femoral_component, &set.femoral_component);
  load(files.tibial_tray, &set.tibial_tray);
  if (load(files.tibial_insert, &set.tibial_insert)) set.insert_generated = false;
  return set;
}

}  // namespace sim
}  // namespace fluoro_tracker
