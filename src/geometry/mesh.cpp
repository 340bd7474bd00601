#include "fluoro_tracker/geometry/mesh.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <unordered_map>

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>

#include "fluoro_tracker/input_error.h"

namespace fluoro_tracker {
namespace geometry {
namespace {

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// Collects every triangle of every mesh node of an imported scene. aiProcess_PreTransformVertices
// has already applied node transforms, so mesh coordinates are in the file's frame.
Mesh meshFromScene(const aiScene& scene, double scale) {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Mesh::Triangle> triangles;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[m];
    const int offset = static_cast<int>(vertices.size());
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      const aiVector3D& p = mesh.mVertices[v];
      vertices.emplace_back(scale * p.x, scale * p.y, scale * p.z);
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines carry no surface
      triangles.emplace_back(offset + static_cast<int>(face.mIndices[0]),
                             offset + static_cast<int>(face.mIndices[1]),
                             offset + static_cast<int>(face.mIndices[2]));
    }
  }
  return Mesh(std::move(vertices), std::move(triangles));
}

// Assimp 5.2's PLY reader never returns on a PLY whose header lacks end_header (a truncated
// file), so such files are rejected before they reach it.
void rejectTruncatedPlyHeader(const std::string& path) {
  if (lowerExtension(path) != ".ply") return;
  std::ifstream in(path, std::ios::binary);
  std::string header(65536, '\0');
  in.read(header.data(), static_cast<std::streamsize>(header.size()));
  header.resize(static_cast<std::size_t>(in.gcount()));
  if (header.rfind("ply", 0) != 0 || header.find("end_header") == std::string::npos) {
    throw InputError("mesh file '" + path +
                     "' could not be parsed (corrupt or unsupported): PLY header is missing "
                     "'ply' or 'end_header' (truncated file?)");
  }
}

struct EdgeUse {
  int forward = 0;   // traversals from the lower to the higher vertex index
  int backward = 0;  // traversals from the higher to the lower vertex index
};

}  // namespace

std::string MeshTopology::describe() const {
  std::ostringstream out;
  out << boundary_edges << " boundary edge(s), " << non_manifold_edges << " non-manifold edge(s), "
      << misoriented_edges << " inconsistently oriented edge(s), " << degenerate_triangles
      << " degenerate triangle(s)";
  return out.str();
}

Mesh::Mesh(std::vector<Eigen::Vector3d> vertices, std::vector<Triangle> triangles)
    : vertices_(std::move(vertices)), triangles_(std::move(triangles)) {
  const int n = static_cast<int>(vertices_.size());
  for (const auto& v : vertices_) {
    if (!v.allFinite()) throw InputError("mesh has a vertex that is not finite");
  }
  for (const auto& t : triangles_) {
    if (t.minCoeff() < 0 || t.maxCoeff() >= n) {
      throw InputError("mesh triangle refers to a vertex index outside [0, " + std::to_string(n) +
                       ")");
    }
  }
}

Mesh Mesh::load(const std::string& path, const MeshLoadOptions& options) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError("mesh file '" + path + "' does not exist");
  if (!fs::is_regular_file(path, ec)) throw InputError("mesh path '" + path + "' is not a file");
  if (fs::file_size(path, ec) == 0) throw InputError("mesh file '" + path + "' is empty");

  rejectTruncatedPlyHeader(path);
  Assimp::Importer importer;
  // Drop per-corner normals, colours and texture coordinates before welding: STL stores the
  // face normal with every corner, which would otherwise keep shared corners apart.
  importer.SetPropertyInteger(
      AI_CONFIG_PP_RVC_FLAGS,
      aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
          aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
          aiComponent_TEXTURES | aiComponent_LIGHTS | aiComponent_CAMERAS | aiComponent_MATERIALS);
  const aiScene* scene =
      importer.ReadFile(path, aiProcess_RemoveComponent | aiProcess_Triangulate |
                                  aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices);
  if (scene == nullptr) {
    throw InputError("mesh file '" + path + "' could not be parsed (corrupt or unsupported): " +
                     importer.GetErrorString());
  }
  Mesh mesh = meshFromScene(*scene, metresPerUnit(options.file_units));
  if (mesh.empty()) throw InputError("mesh file '" + path + "' contains no triangles");

  const MeshTopology topology = mesh.topology();
  if (options.require_closed && !topology.isClosed()) {
    throw InputError("mesh file '" + path +
                     "' is not a closed, consistently oriented surface: " + topology.describe());
  }
  // A closed mesh wound inward has negative volume; turn it outward so normals point out.
  if (topology.isClosed() && mesh.volume() < 0.0) mesh.flipOrientation();
  return mesh;
}

void Mesh::save(const std::string& path, LengthUnit file_units) const {
  const std::string ext = lowerExtension(path);
  std::string format;
  if (ext == ".stl") {
    format = "stlb";
  } else if (ext == ".obj") {
    format = "obj";
  } else if (ext == ".ply") {
    format = "ply";
  } else {
    throw InputError("cannot save mesh '" + path + "': unknown extension (use .stl, .obj or .ply)");
  }
  if (empty()) throw InputError("cannot save mesh '" + path + "': the mesh is empty");

  // aiScene's destructor frees everything below it, so the arrays are allocated with new[].
  aiScene scene;
  scene.mRootNode = new aiNode();
  scene.mMaterials = new aiMaterial* [1] { new aiMaterial() };
  scene.mNumMaterials = 1;
  scene.mMeshes = new aiMesh* [1] { new aiMesh() };
  scene.mNumMeshes = 1;
  scene.mRootNode->mMeshes = new unsigned[1]{0};
  scene.mRootNode->mNumMeshes = 1;

  aiMesh& mesh = *scene.mMeshes[0];
  mesh.mMaterialIndex = 0;
  mesh.mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  const double scale = 1.0 / metresPerUnit(file_units);
  mesh.mNumVertices = static_cast<unsigned>(vertices_.size());
  mesh.mVertices = new aiVector3D[vertices_.size()];
  for (std::size_t i = 0; i < vertices_.size(); ++i) {
    const Eigen::Vector3d p = scale * vertices_[i];
    mesh.mVertices[i] = aiVector3D(static_cast<ai_real>(p.x()), static_cast<ai_real>(p.y()),
                                   static_cast<ai_real>(p.z()));
  }
  mesh.mNumFaces = static_cast<unsigned>(triangles_.size());
  mesh.mFaces = new aiFace[triangles_.size()];
  for (std::size_t i = 0; i < triangles_.size(); ++i) {
    aiFace& face = mesh.mFaces[i];
    face.mNumIndices = 3;
    face.mIndices = new unsigned[3];
    for (int k = 0; k < 3; ++k) face.mIndices[k] = static_cast<unsigned>(triangles_[i][k]);
  }

  Assimp::Exporter exporter;
  if (exporter.Export(&scene, format, path) != aiReturn_SUCCESS) {
    throw InputError("could not write mesh '" + path + "': " + exporter.GetErrorString());
  }
}

std::vector<Eigen::Vector3d> Mesh::faceNormals() const {
  std::vector<Eigen::Vector3d> normals;
  normals.reserve(triangles_.size());
  for (const auto& t : triangles_) {
    const Eigen::Vector3d n =
        (vertices_[t[1]] - vertices_[t[0]]).cross(vertices_[t[2]] - vertices_[t[0]]);
    const double length = n.norm();
    normals.push_back(length > 0.0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero());
  }
  return normals;
}

std::vector<Eigen::Vector3d> Mesh::vertexNormals() const {
  std::vector<Eigen::Vector3d> normals(vertices_.size(), Eigen::Vector3d::Zero());
  for (const auto& t : triangles_) {
    // The unnormalised cross product weights each face by twice its area.
    const Eigen::Vector3d n =
        (vertices_[t[1]] - vertices_[t[0]]).cross(vertices_[t[2]] - vertices_[t[0]]);
    for (int k = 0; k < 3; ++k) normals[t[k]] += n;
  }
  for (auto& n : normals) {
    const double length = n.norm();
    if (length > 0.0) n /= length;
  }
  return normals;
}

double Mesh::surfaceArea() const {
  double area = 0.0;
  for (const auto& t : triangles_) {
    area +=
        0.5 * (vertices_[t[1]] - vertices_[t[0]]).cross(vertices_[t[2]] - vertices_[t[0]]).norm();
  }
  return area;
}

double Mesh::volume() const {
  double six_volume = 0.0;
  for (const auto& t : triangles_) {
    six_volume += vertices_[t[0]].dot(vertices_[t[1]].cross(vertices_[t[2]]));
  }
  return six_volume / 6.0;
}

Eigen::Vector3d Mesh::volumeCentroid() const {
  Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
  double six_volume = 0.0;
  for (const auto& t : triangles_) {
    const double v = vertices_[t[0]].dot(vertices_[t[1]].cross(vertices_[t[2]]));
    six_volume += v;
    weighted += v * (vertices_[t[0]] + vertices_[t[1]] + vertices_[t[2]]) / 4.0;
  }
  if (six_volume == 0.0) return bounds().center();
  return weighted / six_volume;
}

Eigen::AlignedBox3d Mesh::bounds() const {
  Eigen::AlignedBox3d box;
  for (const auto& v : vertices_) box.extend(v);
  return box;
}

MeshTopology Mesh::topology() const {
  MeshTopology result;
  std::unordered_map<std::uint64_t, EdgeUse> edges;
  edges.reserve(triangles_.size() * 2);
  for (const auto& t : triangles_) {
    const double twice_area =
        (vertices_[t[1]] - vertices_[t[0]]).cross(vertices_[t[2]] - vertices_[t[0]]).norm();
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || twice_area == 0.0) {
      ++result.degenerate_triangles;
    }
    for (int k = 0; k < 3; ++k) {
      const int a = t[k];
      const int b = t[(k + 1) % 3];
      EdgeUse& use = edges[undirectedEdgeKey(a, b)];
      if (a < b) {
        ++use.forward;
      } else {
        ++use.backward;
      }
    }
  }
  for (const auto& [key, use] : edges) {
    const int count = use.forward + use.backward;
    if (count == 1) {
      ++result.boundary_edges;
    } else if (count > 2) {
      ++result.non_manifold_edges;
    } else if (use.forward != 1) {
      ++result.misoriented_edges;
    }
  }
  return result;
}

Mesh Mesh::transformed(const Pose& pose) const {
  Mesh out = *this;
  for (auto& v : out.vertices_) v = pose * v;
  return out;
}

Mesh Mesh::scaled(double factor) const {
  Mesh out = *this;
  for (auto& v : out.vertices_) v *= factor;
  return out;
}

Mesh Mesh::mirrored(int axis) const {
  if (axis < 0 || axis > 2) throw InputError("mesh: mirror axis must be 0, 1 or 2");
  Mesh out = *this;
  for (auto& v : out.vertices_) v[axis] = -v[axis];
  out.flipOrientation();
  return out;
}

void Mesh::flipOrientation() {
  for (auto& t : triangles_) std::swap(t[1], t[2]);
}

void Mesh::append(const Mesh& other) {
  const int offset = static_cast<int>(vertices_.size());
  vertices_.insert(vertices_.end(), other.vertices_.begin(), other.vertices_.end());
  for (const auto& t : other.triangles_) triangles_.push_back(t + Triangle::Constant(offset));
}

}  // namespace geometry
}  // namespace fluoro_tracker
