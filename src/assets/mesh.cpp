#include "volcast/assets/mesh.hpp"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <map>
#include <tuple>
#include <unordered_map>

#include "volcast/core/error.hpp"

namespace volcast {

TriangleMesh read_mesh_file(const std::filesystem::path& path) {
  Assimp::Importer importer;
  // Meshes only: no lights, cameras, materials' textures or animations are read.
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_NORMALS | aiComponent_COLORS |
                                                          aiComponent_TEXCOORDS |
                                                          aiComponent_ANIMATIONS |
                                                          aiComponent_LIGHTS | aiComponent_CAMERAS);
  const aiScene* scene = importer.ReadFile(
      path.string(), aiProcess_RemoveComponent | aiProcess_Triangulate |
                         aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices |
                         aiProcess_SortByPType | aiProcess_FindDegenerates);
  if (!scene || !scene->mRootNode)
    throw Error("mesh " + path.string() + ": " + importer.GetErrorString());
  TriangleMesh out;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    if (!(mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    const auto base = static_cast<uint32_t>(out.positions.size());
    for (unsigned v = 0; v < mesh->mNumVertices; ++v)
      out.positions.emplace_back(mesh->mVertices[v].x, mesh->mVertices[v].y, mesh->mVertices[v].z);
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines left by degenerate removal
      for (int i = 0; i < 3; ++i) out.indices.push_back(base + face.mIndices[i]);
    }
  }
  if (out.indices.empty()) throw Error("mesh " + path.string() + ": no triangles in it");
  for (const Eigen::Vector3f& p : out.positions)
    if (!p.allFinite()) throw Error("mesh " + path.string() + ": a vertex is not finite");
  compute_normals(out);
  return out;
}

BoundingBox bounding_box(const TriangleMesh& mesh) {
  BoundingBox b;
  for (const Eigen::Vector3f& p : mesh.positions) b.extend(p);
  return b;
}

double enclosed_volume(const TriangleMesh& mesh) {
  // Relative to the box centre, so that large coordinates do not cost precision.
  const Eigen::Vector3d c = bounding_box(mesh).center().cast<double>();
  double six_v = 0;
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const Eigen::Vector3d a = mesh.positions[mesh.indices[t]].cast<double>() - c;
    const Eigen::Vector3d b = mesh.positions[mesh.indices[t + 1]].cast<double>() - c;
    const Eigen::Vector3d d = mesh.positions[mesh.indices[t + 2]].cast<double>() - c;
    six_v += a.dot(b.cross(d));
  }
  return std::abs(six_v) / 6;
}

bool is_closed(const TriangleMesh& mesh) {
  // Weld by exact position, then count each undirected edge.
  std::map<std::tuple<float, float, float>, uint32_t> weld;
  std::vector<uint32_t> id(mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Eigen::Vector3f& p = mesh.positions[i];
    id[i] =
        weld.try_emplace({p.x(), p.y(), p.z()}, static_cast<uint32_t>(weld.size())).first->second;
  }
  std::unordered_map<uint64_t, int> edges;
  edges.reserve(mesh.indices.size());
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3)
    for (int e = 0; e < 3; ++e) {
      uint64_t a = id[mesh.indices[t + e]], b = id[mesh.indices[t + (e + 1) % 3]];
      if (a == b) return false;  // a degenerate triangle
      if (a > b) std::swap(a, b);
      ++edges[(a << 32) | b];
    }
  if (edges.empty()) return false;
  for (const auto& [edge, count] : edges)
    if (count != 2) return false;
  return true;
}

void compute_normals(TriangleMesh& mesh) {
  std::vector<Eigen::Vector3f> sum(mesh.positions.size(), Eigen::Vector3f::Zero());
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const uint32_t i0 = mesh.indices[t], i1 = mesh.indices[t + 1], i2 = mesh.indices[t + 2];
    const Eigen::Vector3f n =
        (mesh.positions[i1] - mesh.positions[i0]).cross(mesh.positions[i2] - mesh.positions[i0]);
    sum[i0] += n, sum[i1] += n, sum[i2] += n;
  }
  for (Eigen::Vector3f& n : sum)
    n = n.norm() > 0 ? Eigen::Vector3f(n.normalized()) : Eigen::Vector3f::UnitZ();
  mesh.normals = std::move(sum);
}

}  // namespace volcast
