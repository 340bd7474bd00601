#include "fluoro_tracker/constraints/articular_contact.h"

#include <cmath>

#include <gtest/gtest.h>

#include "../test_support.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/registration/contact_cost.h"
#include "fluoro_tracker/sim/mesh_builder.h"

namespace fluoro_tracker {
namespace constraints {
namespace {

using geometry::Mesh;
using geometry::Pose;

Pose translation(double x, double y, double z) {
  Pose p = Pose::Identity();
  p.translation() = Eigen::Vector3d(x, y, z);
  return p;
}

ContactSettings withMeasure(ContactMeasure measure) {
  ContactSettings s;
  s.measure = measure;
  s.exponent = 1.0;
  return s;
}

// A sphere of radius R (the sampled parent) pressed h deep into the flat top of a block (the
// gridded child): depth h, cap area 2 pi R h, quasi-volume = integral of the depth over the
// cap = pi R h^2.
TEST(ArticularContact, SphereOnPlaneMatchesTheClosedForms) {
  const double r_mm = 20.0;
  const double h_mm = 2.0;
  const Mesh sphere = sim::uvSphere(r_mm * 1e-3, 128, 256);
  const Mesh block = sim::box(Eigen::Vector3d(0.04, 0.01, 0.04));  // top face at y = 10 mm
  const ArticularContact contact(sphere, block, withMeasure(ContactMeasure::kQuasiVolume));
  const Pose sphere_pose = translation(0.0, (10.0 + r_mm - h_mm) * 1e-3, 0.0);
  const ContactFigures f = contact.figures(sphere_pose, Pose::Identity(), true);
  EXPECT_TRUE(f.in_collision);
  EXPECT_NEAR(f.max_depth_m * 1e3, h_mm, 0.02 * h_mm);
  EXPECT_NEAR(f.area_m2 * 1e6, 2.0 * M_PI * r_mm * h_mm, 0.02 * 2.0 * M_PI * r_mm * h_mm);
  EXPECT_NEAR(f.quasi_volume_m3 * 1e9, M_PI * r_mm * h_mm * h_mm, 0.02 * M_PI * r_mm * h_mm * h_mm);
  EXPECT_NEAR(f.measure, f.quasi_volume_m3 * 1e9, 1e-9);
  EXPECT_NEAR(f.min_distance_m, -f.max_depth_m, 1e-12);
  ASSERT_FALSE(f.points.empty());
  for (const auto& p : f.points) EXPECT_LT(p.position.y(), 0.0101);
}

// A coarse parent: a block of 12 triangles (as a vendor's model draws a flat face, e.g. a
// posterior-stabilised box's wall) with a sphere (R = 20 mm, the gridded child) pressed h = 2 mm
// into the middle of its top face, where no vertex lies. Sampled at its vertices only, the
// penetration goes unseen; split into triangles of 1 mm or less it matches the closed forms:
// depth h, area pi a^2 with a^2 = R^2 - d^2, d = R - h, and quasi-volume
// 2 pi [R a^2 / 2 - (R^3 - d^3) / 3]. The default spacing (3 mm) sees it too.
TEST(ArticularContact, LargeTrianglesAreSampledInside) {
  const double r_mm = 20.0;
  const double h_mm = 2.0;
  const double d = r_mm - h_mm;
  const double a2 = r_mm * r_mm - d * d;
  const Mesh block = sim::box(Eigen::Vector3d(0.02, 0.01, 0.02));  // top face at y = 10 mm
  const Mesh sphere = sim::uvSphere(r_mm * 1e-3, 128, 256);
  const Pose sphere_pose = translation(0.0, (10.0 + d) * 1e-3, 0.0);
  ContactSettings settings = withMeasure(ContactMeasure::kQuasiVolume);
  settings.max_sample_spacing_mm = 0.0;
  const ContactFigures vertices_only =
      ArticularContact(block, sphere, settings).sampledFigures(Pose::Identity(), sphere_pose);
  EXPECT_EQ(vertices_only.max_depth_m, 0.0);
  settings.max_sample_spacing_mm = 0.99;  // the 56.6 mm diagonals split 58 times
  const ContactFigures fine =
      ArticularContact(block, sphere, settings).sampledFigures(Pose::Identity(), sphere_pose);
  const double area = M_PI * a2;
  const double volume = 2.0 * M_PI * (r_mm * a2 / 2.0 - (std::pow(r_mm, 3) - std::pow(d, 3)) / 3.0);
  EXPECT_NEAR(fine.max_depth_m * 1e3, h_mm, 0.02 * h_mm);
  EXPECT_NEAR(fine.area_m2 * 1e6, area, 0.02 * area);
  EXPECT_NEAR(fine.quasi_volume_m3 * 1e9, volume, 0.02 * volume);
  const ContactFigures by_default =
      ArticularContact(block, sphere, withMeasure(ContactMeasure::kQuasiVolume))
          .sampledFigures(Pose::Identity(), sphere_pose);
  EXPECT_NEAR(by_default.max_depth_m * 1e3, h_mm, 0.1 * h_mm);
  EXPECT_NEAR(by_default.quasi_volume_m3 * 1e9, volume, 0.1 * volume);
}

// Two overlapping spheres (r sampled, R gridded, centres c apart): depth r + R - c; the part of
// the small sphere inside the big one is a cap of height r - (c^2 + r^2 - R^2) / 2c; the
// integral of the depth R - |p - cB| over it is (2 pi r / c) [R s^2/2 - s^3/3] from c - r to R.
TEST(ArticularContact, SphereInSphereMatchesTheClosedForms) {
  const double r = 15.0;
  const double big = 25.0;
  const double c = 38.0;
  const Mesh small_sphere = sim::uvSphere(r * 1e-3, 128, 256);
  const Mesh big_sphere = sim::uvSphere(big * 1e-3, 96, 192);
  const ArticularContact contact(small_sphere, big_sphere,
                                 withMeasure(ContactMeasure::kQuasiVolume));
  const ContactFigures f = contact.figures(translation(c * 1e-3, 0, 0), Pose::Identity());
  const double depth = r + big - c;
  const double cap_height = r - (c * c + r * r - big * big) / (2.0 * c);
  const double area = 2.0 * M_PI * r * cap_height;
  auto primitive = [&](double s) { return big * s * s / 2.0 - s * s * s / 3.0; };
  const double volume = 2.0 * M_PI * r / c * (primitive(big) - primitive(c - r));
  EXPECT_NEAR(f.max_depth_m * 1e3, depth, 0.02 * depth);
  EXPECT_NEAR(f.area_m2 * 1e6, area, 0.02 * area);
  EXPECT_NEAR(f.quasi_volume_m3 * 1e9, volume, 0.02 * volume);

  // A small sphere wholly inside, off centre: every point penetrates, so the area is the whole
  // sphere; a point's depth is R - |p|, largest at the point nearest the big sphere's centre.
  const double offset = 3.0;
  const double inner = 8.0;
  const ArticularContact inside(sim::uvSphere(inner * 1e-3, 96, 192), big_sphere,
                                withMeasure(ContactMeasure::kPenetrationArea));
  const ContactFigures g = inside.figures(translation(offset * 1e-3, 0, 0), Pose::Identity());
  EXPECT_NEAR(g.area_m2 * 1e6, 4.0 * M_PI * inner * inner, 0.02 * 4.0 * M_PI * inner * inner);
  // Deepest sample: the one nearest the big sphere's centre, at |p| = inner - offset.
  const double deepest = big - (inner - offset);
  EXPECT_NEAR(g.max_depth_m * 1e3, deepest, 0.05 * deepest);  // chamfer region: a few %
  EXPECT_NEAR(g.measure, g.area_m2 * 1e6, 1e-9);
}

TEST(ArticularContact, SeparatedSurfacesReportNoPenetrationAndTheirGap) {
  const Mesh small_sphere = sim::uvSphere(0.015, 64, 128);
  const Mesh big_sphere = sim::uvSphere(0.025, 64, 128);
  const ArticularContact separation(small_sphere, big_sphere,
                                    withMeasure(ContactMeasure::kSeparation));
  const ContactFigures f = separation.figures(translation(0.042, 0, 0), Pose::Identity(), true);
  EXPECT_FALSE(f.in_collision);
  EXPECT_EQ(f.max_depth_m, 0.0);
  EXPECT_EQ(f.area_m2, 0.0);
  EXPECT_EQ(f.quasi_volume_m3, 0.0);
  EXPECT_TRUE(f.points.empty());
  EXPECT_NEAR(f.min_distance_m, 0.002, 5e-5);  // FCL
  EXPECT_NEAR(f.measure, 2.0, 0.05);           // the grid's gap, mm
  // Overlapping: no separation penalty; sign of the measure follows the gap.
  EXPECT_EQ(separation.figures(translation(0.038, 0, 0), Pose::Identity()).measure, 0.0);
  // A dead band: gaps below it cost nothing.
  ContactSettings allowed = withMeasure(ContactMeasure::kSeparation);
  allowed.dead_band_mm = 2.5;
  EXPECT_EQ(ArticularContact(small_sphere, big_sphere, allowed)
                .figures(translation(0.042, 0, 0), Pose::Identity())
                .measure,
            0.0);
}

// figures() is sampledFigures() with FCL's collision and separation added: the registrar
// compares solutions by the sampled figures and adds FCL's to the one it keeps.
TEST(ArticularContact, SampledFiguresAndSeparationMakeUpTheFigures) {
  const Mesh small_sphere = sim::uvSphere(0.015, 32, 64);
  const Mesh big_sphere = sim::uvSphere(0.025, 32, 64);
  const ArticularContact contact(small_sphere, big_sphere,
                                 withMeasure(ContactMeasure::kQuasiVolume));
  for (double x : {0.042, 0.038}) {  // apart by 2 mm; overlapping by 2 mm
    const Pose parent = translation(x, 0, 0);
    const ContactFigures whole = contact.figures(parent, Pose::Identity(), true);
    ContactFigures sampled = contact.sampledFigures(parent, Pose::Identity(), true);
    EXPECT_FALSE(sampled.in_collision) << x;
    EXPECT_EQ(sampled.min_distance_m, 0.0) << x;
    contact.addSeparation(parent, Pose::Identity(), &sampled);
    EXPECT_EQ(sampled.in_collision, whole.in_collision) << x;
    EXPECT_EQ(sampled.min_distance_m, whole.min_distance_m) << x;
    EXPECT_EQ(sampled.max_depth_m, whole.max_depth_m) << x;
    EXPECT_EQ(sampled.area_m2, whole.area_m2) << x;
    EXPECT_EQ(sampled.quasi_volume_m3, whole.quasi_volume_m3) << x;
    EXPECT_EQ(sampled.measure, whole.measure) << x;
    EXPECT_EQ(sampled.penalty, whole.penalty) << x;
    EXPECT_EQ(sampled.points.size(), whole.points.size()) << x;
  }
  EXPECT_TRUE(contact.figures(translation(0.038, 0, 0), Pose::Identity()).in_collision);
  EXPECT_GT(contact.figures(translation(0.042, 0, 0), Pose::Identity()).min_distance_m, 0.001);
}

TEST(ArticularContact, DeadBandAndExponentShapeThePenalty) {
  const Mesh sphere = sim::uvSphere(0.02, 64, 128);
  const Mesh block = sim::box(Eigen::Vector3d(0.04, 0.01, 0.04));
  ContactSettings settings = withMeasure(ContactMeasure::kPenetrationDepth);
  settings.dead_band_mm = 1.0;
  settings.weight = 50.0;
  const ArticularContact contact(sphere, block, settings);
  const ContactFigures shallow = contact.figures(translation(0, 0.0295, 0), Pose::Identity());
  EXPECT_NEAR(shallow.max_depth_m, 0.0005, 2e-5);
  EXPECT_EQ(shallow.measure, 0.0);  // inside the dead band
  const ContactFigures deep = contact.figures(translation(0, 0.0275, 0), Pose::Identity());
  EXPECT_NEAR(deep.measure, 1.5, 0.03);  // 2.5 mm deep, 1 mm dead band
  EXPECT_NEAR(deep.penalty, 50.0 * 1.5, 1.5);
  double slope = 0.0;
  contact.penalty(1.5, &slope);
  EXPECT_NEAR(slope, 50.0, 1e-3);
}

TEST(ArticularContact, RejectsAnOpenChildSurfaceAnEmptyRegionAndBadNames) {
  Mesh open = sim::box(Eigen::Vector3d::Constant(0.01));
  open = Mesh(open.vertices(), {open.triangles().begin(), open.triangles().end() - 1});
  const Mesh sphere = sim::uvSphere(0.01, 16, 32);
  EXPECT_THROW_WITH(ArticularContact(sphere, open, ContactSettings()), "must be closed");
  ContactSettings nowhere;
  nowhere.region.box =
      Eigen::AlignedBox3d(Eigen::Vector3d::Constant(1.0), Eigen::Vector3d::Constant(2.0));
  EXPECT_THROW_WITH(ArticularContact(sphere, sphere, nowhere), "selects no triangle");
  ContactSettings negative_spacing;
  negative_spacing.max_sample_spacing_mm = -1.0;
  EXPECT_THROW_WITH(ArticularContact(sphere, sphere, negative_spacing), "max_sample_spacing_mm");
  ContactSettings minute_spacing;
  minute_spacing.max_sample_spacing_mm = 1e-4;
  EXPECT_THROW_WITH(ArticularContact(sphere, sphere, minute_spacing), "5 million");
  EXPECT_THROW_WITH(contactMeasureFromName("volume"), "quasi_volume");
  EXPECT_EQ(contactMeasureFromName("elastic_energy"), ContactMeasure::kElasticEnergy);
}

// The measure over a part (the samples near the child, as the contact cost culls them) equals
// the measure over every sample, value and derivatives, when the rest read as far outside.
TEST(ArticularContact, MeasureOverAPartMatchesTheWholeSurface) {
  const Mesh sphere = sim::uvSphere(0.02, 48, 96);
  const Mesh block = sim::box(Eigen::Vector3d(0.04, 0.01, 0.04));
  for (ContactMeasure measure : {ContactMeasure::kPenetrationDepth,
                                 ContactMeasure::kPenetrationArea, ContactMeasure::kQuasiVolume,
                                 ContactMeasure::kElasticEnergy, ContactMeasure::kSeparation}) {
    // 1.5 mm deep; 2 mm apart for the separation.
    const bool apart = measure == ContactMeasure::kSeparation;
    const Pose sphere_pose = translation(0.002, apart ? 0.032 : 0.0285, -0.001);
    ContactSettings settings = withMeasure(measure);
    settings.dead_band_mm = 0.5;
    const ArticularContact contact(sphere, block, settings);
    const std::size_t n = contact.samples().size();
    std::vector<int> near;
    std::vector<double> distances(n, 1.0);
    for (std::size_t i = 0; i < n; ++i) {
      const double d = contact.grid().distance(sphere_pose * contact.samples()[i]);
      // A tight cut, so that triangles straddle it.
      if (d < (apart ? 0.004 : -0.0003)) {
        near.push_back(static_cast<int>(i));
        distances[i] = d;
      }
    }
    ASSERT_GT(near.size(), 10u);
    ASSERT_LT(near.size(), n / 2);
    const auto part = contact.subset(near);
    EXPECT_LT(part.triangles.size(), n);
    std::vector<double> whole_gradient(n, 7.0);
    std::vector<double> part_gradient(n, 7.0);  // stale values the part must overwrite
    const double whole = contact.measure(distances.data(), whole_gradient.data());
    const double from_part = contact.measure(distances.data(), part_gradient.data(), part);
    EXPECT_GT(whole, 0.0) << contactMeasureName(measure);
    EXPECT_NEAR(from_part, whole, 1e-12 * std::max(1.0, whole)) << contactMeasureName(measure);
    for (int i : near) {
      EXPECT_NEAR(part_gradient[i], whole_gradient[i], 1e-9) << contactMeasureName(measure);
    }
  }
}

// The cost's analytic Jacobians against central differences, for every measure.
TEST(ContactCost, JacobiansMatchFiniteDifferences) {
  const Mesh sphere = sim::uvSphere(0.02, 48, 96);
  const Mesh block = sim::box(Eigen::Vector3d(0.04, 0.01, 0.04));
  Pose block_pose = Pose::Identity();
  block_pose.linear() =
      Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.3, 0.2, 1).normalized()).toRotationMatrix();
  block_pose.translation() = Eigen::Vector3d(0.01, -0.02, 0.9);
  const Pose sphere_pose = block_pose * translation(0.003, 0.0285, -0.002);
  for (ContactMeasure measure :
       {ContactMeasure::kPenetrationDepth, ContactMeasure::kPenetrationArea,
        ContactMeasure::kQuasiVolume, ContactMeasure::kElasticEnergy}) {
    ContactSettings settings;
    settings.measure = measure;
    const ArticularContact contact(sphere, block, settings);
    const Eigen::Vector3d sphere_centre = sphere_pose.translation();
    const Eigen::Vector3d block_centre = block_pose.translation();
    const registration::ContactCost cost(&contact, sphere_pose, sphere_centre, block_pose,
                                         block_centre);
    double increments[2][6] = {{0.01, -0.02, 0.015, 1e-4, -2e-4, 1e-4},
                               {-0.01, 0.005, 0.02, -1e-4, 1e-4, 2e-4}};
    const double* parameters[2] = {increments[0], increments[1]};
    double residual = 0.0;
    double jacobian[2][6];
    double* jacobians[2] = {jacobian[0], jacobian[1]};
    ASSERT_TRUE(cost.Evaluate(parameters, &residual, jacobians));
    EXPECT_GT(residual, 0.0) << contactMeasureName(measure);
    for (int block_index = 0; block_index < 2; ++block_index) {
      for (int k = 0; k < 6; ++k) {
        const double step = k < 3 ? 1e-5 : 1e-7;
        double plus = 0.0;
        double minus = 0.0;
        increments[block_index][k] += step;
        cost.Evaluate(parameters, &plus, nullptr);
        increments[block_index][k] -= 2.0 * step;
        cost.Evaluate(parameters, &minus, nullptr);
        increments[block_index][k] += step;
        const double numeric = (plus - minus) / (2.0 * step);
        // Trilinear gradients are piecewise constant: a few percent between the two.
        EXPECT_NEAR(jacobian[block_index][k], numeric, 0.05 * std::abs(numeric) + 1e-6)
            << contactMeasureName(measure) << " block " << block_index << " parameter " << k;
      }
    }
  }
}

}  // namespace
}  // namespace constraints
}  // namespace fluoro_tracker
