#include "fluoro_tracker/geometry/mesh.h"

#include <fcl/narrowphase/collision.h>

#include "../test_support.h"
#include "fluoro_tracker/geometry/mesh_bvh.h"
#include "fluoro_tracker/sim/mesh_builder.h"

using namespace fluoro_tracker;
using geometry::LengthUnit;
using geometry::Mesh;
using geometry::MeshLoadOptions;
using test_support::TempDir;

namespace {

Mesh unitCube() {
  return sim::box(Eigen::Vector3d(0.5, 0.5, 0.5));
}

MeshLoadOptions inMetres() {
  MeshLoadOptions o;
  o.file_units = LengthUnit::kMetre;
  return o;
}

}  // namespace

TEST(Mesh, UnitCubeProperties) {
  const Mesh cube = unitCube();
  EXPECT_EQ(cube.vertexCount(), 8u);
  EXPECT_EQ(cube.triangleCount(), 12u);
  EXPECT_NEAR(cube.volume(), 1.0, 1e-12);
  EXPECT_NEAR(cube.surfaceArea(), 6.0, 1e-12);
  EXPECT_TRUE(cube.topology().isClosed());
  EXPECT_TRUE(cube.volumeCentroid().isZero(1e-12));
  // Face normals point away from the centre.
  const auto normals = cube.faceNormals();
  for (std::size_t i = 0; i < cube.triangleCount(); ++i) {
    const auto& t = cube.triangles()[i];
    const Eigen::Vector3d centre =
        (cube.vertices()[t[0]] + cube.vertices()[t[1]] + cube.vertices()[t[2]]) / 3.0;
    EXPECT_GT(normals[i].dot(centre), 0.0);
    EXPECT_NEAR(normals[i].norm(), 1.0, 1e-12);
  }
  // Vertex normals of a cube corner point along the diagonal.
  for (std::size_t i = 0; i < cube.vertexCount(); ++i) {
    EXPECT_GT(cube.vertexNormals()[i].dot(cube.vertices()[i].normalized()), 0.5);
  }
}

TEST(Mesh, SphereVolumeAndAreaApproachClosedForm) {
  const Mesh sphere = sim::uvSphere(1.0, 96, 192);
  EXPECT_NEAR(sphere.volume(), 4.0 / 3.0 * M_PI, 4.0 / 3.0 * M_PI * 2e-3);
  EXPECT_NEAR(sphere.surfaceArea(), 4.0 * M_PI, 4.0 * M_PI * 2e-3);
  EXPECT_TRUE(sphere.topology().isClosed());
}

TEST(Mesh, TopologyFindsHolesAndMisorientation) {
  Mesh cube = unitCube();
  std::vector<Mesh::Triangle> open(cube.triangles().begin(), cube.triangles().end() - 1);
  const Mesh holed(cube.vertices(), open);
  EXPECT_EQ(holed.topology().boundary_edges, 3u);
  EXPECT_FALSE(holed.topology().isClosed());

  std::vector<Mesh::Triangle> flipped = cube.triangles();
  std::swap(flipped[0][1], flipped[0][2]);
  const Mesh misoriented(cube.vertices(), flipped);
  EXPECT_GT(misoriented.topology().misoriented_edges, 0u);
  EXPECT_FALSE(misoriented.topology().isClosed());
}

TEST(Mesh, MirroredStaysOutwardAndReflectsOneAxis) {
  // A box off the origin, so that the reflection moves it.
  const Mesh box = sim::box(Eigen::Vector3d(0.1, 0.2, 0.3))
                       .transformed(geometry::makePose(Eigen::Matrix3d::Identity(),
                                                       Eigen::Vector3d(0.5, 0.6, 0.7)));
  for (int axis = 0; axis < 3; ++axis) {
    const Mesh mirror = box.mirrored(axis);
    EXPECT_TRUE(mirror.topology().isClosed()) << axis;
    EXPECT_NEAR(mirror.volume(), box.volume(), 1e-12) << axis;  // > 0: still outward
    Eigen::Vector3d expected = box.volumeCentroid();
    expected[axis] = -expected[axis];
    EXPECT_TRUE(mirror.volumeCentroid().isApprox(expected, 1e-12)) << axis;
  }
  EXPECT_THROW_WITH(box.mirrored(3), "mirror axis");
}

TEST(Mesh, RejectsOutOfRangeIndices) {
  EXPECT_THROW_WITH(Mesh({Eigen::Vector3d::Zero()}, {Mesh::Triangle(0, 1, 2)}), "vertex index");
}

class MeshFormatRoundTrip : public ::testing::TestWithParam<std::string> {};

TEST_P(MeshFormatRoundTrip, SaveAndLoadPreservesGeometryInBothUnits) {
  TempDir dir;
  const Mesh original = sim::uvSphere(0.03, 24, 48);
  for (LengthUnit unit : {LengthUnit::kMillimetre, LengthUnit::kMetre}) {
    const std::string path = dir.file("mesh" + GetParam());
    original.save(path, unit);
    MeshLoadOptions options;
    options.file_units = unit;
    const Mesh loaded = Mesh::load(path, options);
    EXPECT_EQ(loaded.triangleCount(), original.triangleCount());
    EXPECT_EQ(loaded.vertexCount(), original.vertexCount()) << "vertices were not welded";
    EXPECT_NEAR(loaded.volume(), original.volume(), 1e-6 * original.volume());
    EXPECT_NEAR(loaded.surfaceArea(), original.surfaceArea(), 1e-6 * original.surfaceArea());
    EXPECT_TRUE(loaded.bounds().min().isApprox(original.bounds().min(), 1e-6));
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, MeshFormatRoundTrip, ::testing::Values(".stl", ".obj", ".ply"));

TEST(Mesh, LoadsAsciiStl) {
  TempDir dir;
  // A tetrahedron written by hand in ASCII STL, millimetres.
  const std::string path = dir.file("tetra.stl");
  test_support::writeText(path,
                          "solid tetra\n"
                          "facet normal 0 0 -1\n outer loop\n  vertex 0 0 0\n  vertex 0 10 0\n  "
                          "vertex 10 0 0\n endloop\nendfacet\n"
                          "facet normal 0 -1 0\n outer loop\n  vertex 0 0 0\n  vertex 10 0 0\n  "
                          "vertex 0 0 10\n endloop\nendfacet\n"
                          "facet normal -1 0 0\n outer loop\n  vertex 0 0 0\n  vertex 0 0 10\n  "
                          "vertex 0 10 0\n endloop\nendfacet\n"
                          "facet normal 1 1 1\n outer loop\n  vertex 10 0 0\n  vertex 0 10 0\n  "
                          "vertex 0 0 10\n endloop\nendfacet\n"
                          "endsolid tetra\n");
  const Mesh mesh = Mesh::load(path);
  EXPECT_EQ(mesh.vertexCount(), 4u);
  EXPECT_EQ(mesh.triangleCount(), 4u);
  EXPECT_NEAR(mesh.volume(), 1e-9 * 1000.0 / 6.0, 1e-15);  // (10 mm)^3 / 6 in m^3
}

TEST(Mesh, InwardWoundClosedMeshIsTurnedOutward) {
  TempDir dir;
  Mesh inward = unitCube();
  inward.flipOrientation();
  ASSERT_LT(inward.volume(), 0.0);
  inward.save(dir.file("inward.stl"), LengthUnit::kMetre);
  const Mesh loaded = Mesh::load(dir.file("inward.stl"), inMetres());
  EXPECT_NEAR(loaded.volume(), 1.0, 1e-6);
}

TEST(Mesh, BadFilesGiveErrorsNamingTheProblem) {
  TempDir dir;
  EXPECT_THROW_WITH(Mesh::load(dir.file("missing.stl")), "does not exist");

  test_support::writeText(dir.file("empty.stl"), "");
  EXPECT_THROW_WITH(Mesh::load(dir.file("empty.stl")), "is empty");

  test_support::writeText(dir.file("corrupt.stl"),
                          "solid x\nfacet normal nonsense\n vertex 1 2\n@@@@\n");
  EXPECT_THROW_WITH(Mesh::load(dir.file("corrupt.stl")), "could not be parsed");

  test_support::writeText(dir.file("garbage.ply"),
                          std::string("ply\nformat ascii 1.0\nelement vertex 3\n"));
  EXPECT_THROW_WITH(Mesh::load(dir.file("garbage.ply")), "garbage.ply");

  const Mesh cube = unitCube();
  const Mesh open(cube.vertices(), std::vector<Mesh::Triangle>(cube.triangles().begin(),
                                                               cube.triangles().end() - 2));
  open.save(dir.file("open.stl"), LengthUnit::kMetre);
  EXPECT_THROW_WITH(Mesh::load(dir.file("open.stl"), inMetres()), "not a closed");
  MeshLoadOptions lenient = inMetres();
  lenient.require_closed = false;
  EXPECT_EQ(Mesh::load(dir.file("open.stl"), lenient).triangleCount(), 10u);
}

TEST(Mesh, RealImplantModelsLoadClosed) {
  MeshLoadOptions options;  // the Kneel STLs are in millimetres
  const Mesh femur =
      Mesh::load(test_support::sharedData("jointtrack_kneel/KR_right_7_fem.stl"), options);
  const Mesh tibia =
      Mesh::load(test_support::sharedData("jointtrack_kneel/KR_right_6_tib.stl"), options);
  EXPECT_EQ(femur.triangleCount(), 12412u);
  EXPECT_EQ(tibia.triangleCount(), 15000u);
  EXPECT_TRUE(femur.topology().isClosed()) << femur.topology().describe();
  EXPECT_GT(femur.volume(), 0.0);
  // A femoral component is a few centimetres across and holds 10-100 cm^3 of metal.
  const Eigen::Vector3d size = femur.bounds().sizes();
  EXPECT_GT(size.maxCoeff(), 0.04);
  EXPECT_LT(size.maxCoeff(), 0.12);
  EXPECT_GT(femur.volume(), 10e-6);
  EXPECT_LT(femur.volume(), 100e-6);
}

TEST(Mesh, FclBvhCollidesOverlappingMeshesOnly) {
  const Mesh sphere = sim::uvSphere(0.02, 24, 48);
  const auto bvh = geometry::buildBvh(sphere);
  EXPECT_EQ(bvh->num_tris, static_cast<int>(sphere.triangleCount()));
  const fcl::CollisionObjectd a(bvh);
  fcl::CollisionObjectd b(bvh);
  fcl::CollisionRequestd request;
  fcl::CollisionResultd result;
  b.setTranslation(Eigen::Vector3d(0.03, 0.0, 0.0));  // surfaces overlap
  fcl::collide(&a, &b, request, result);
  EXPECT_TRUE(result.isCollision());
  result.clear();
  b.setTranslation(Eigen::Vector3d(0.05, 0.0, 0.0));  // 1 cm apart
  fcl::collide(&a, &b, request, result);
  EXPECT_FALSE(result.isCollision());
  EXPECT_THROW_WITH(geometry::buildBvh(Mesh()), "empty mesh");
}
