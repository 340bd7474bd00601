#pragma once

#include <memory>

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/OBBRSS.h>

#include "fluoro_tracker/geometry/mesh.h"

namespace fluoro_tracker {
namespace geometry {

// FCL bounding-volume hierarchy of a mesh in its own frame, built once per mesh and reused by
// every proximity query (OBBRSS supports both collision and distance queries).
using MeshBvh = fcl::BVHModel<fcl::OBBRSSd>;

std::shared_ptr<MeshBvh> buildBvh(const Mesh& mesh);

}  // namespace geometry
}  // namespace fluoro_tracker
