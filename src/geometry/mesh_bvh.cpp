// The only translation unit that instantiates FCL's BVH templates for mesh construction, so
// that the heavy headers are compiled once.
#include "fluoro_tracker/geometry/mesh_bvh.h"

#include <vector>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace geometry {

std::shared_ptr<MeshBvh> buildBvh(const Mesh& mesh) {
  if (mesh.empty()) throw InputError("cannot build a BVH for an empty mesh");
  std::vector<fcl::Triangle> triangles;
  triangles.reserve(mesh.triangleCount());
  for (const auto& t : mesh.triangles()) triangles.emplace_back(t[0], t[1], t[2]);
  auto bvh = std::make_shared<MeshBvh>();
  if (bvh->beginModel(static_cast<int>(triangles.size()), static_cast<int>(mesh.vertexCount())) !=
          fcl::BVH_OK ||
      bvh->addSubModel(mesh.vertices(), triangles) != fcl::BVH_OK ||
      bvh->endModel() != fcl::BVH_OK) {
    throw InputError("FCL could not build a BVH for a mesh of " +
                     std::to_string(mesh.triangleCount()) + " triangles");
  }
  bvh->computeLocalAABB();
  return bvh;
}

}  // namespace geometry
}  // namespace fluoro_tracker
