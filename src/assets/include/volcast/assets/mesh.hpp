#pragma once
// Triangle meshes of a patient's anatomy (organ surfaces), as read from mesh files or extracted
// from label volumes (label_volume.hpp). Positions stay in the frame the data came in: the case
// frame, millimetres (3D-IRCADb's OBJ meshes and label volumes share one such frame).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace volcast {

/// An indexed triangle mesh: positions (millimetres, case frame), one unit normal per position
/// (averaged over the triangles around it, or empty), and three indices per triangle, counter-
/// clockwise seen from outside for a closed surface.
struct TriangleMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;
  std::vector<uint32_t> indices;
  size_t triangles() const { return indices.size() / 3; }
};

/// An axis-aligned box (millimetres, case frame); empty when min > max.
struct BoundingBox {
  Eigen::Vector3f min = Eigen::Vector3f::Constant(1e30f);
  Eigen::Vector3f max = Eigen::Vector3f::Constant(-1e30f);
  bool empty() const { return (min.array() > max.array()).any(); }
  Eigen::Vector3f center() const { return (min + max) / 2; }
  Eigen::Vector3f size() const {
    return empty() ? Eigen::Vector3f::Zero() : Eigen::Vector3f(max - min);
  }
  void extend(const Eigen::Vector3f& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  void extend(const BoundingBox& b) {
    if (!b.empty()) extend(b.min), extend(b.max);
  }
};

/// Reads every mesh of an OBJ, STL, PLY, glTF (.gltf/.glb) or other Assimp-readable file,
/// triangulated, identical vertices joined, node transforms applied, as one mesh with smooth
/// normals. Units are the file's (our cases: millimetres). Throws Error naming the file when it
/// cannot be read or holds no triangles.
TriangleMesh read_mesh_file(const std::filesystem::path& path);

/// The bounding box of the positions.
BoundingBox bounding_box(const TriangleMesh& mesh);
/// The volume a closed mesh encloses (mm^3 for positions in mm): the sum of the signed volumes of
/// the tetrahedra (origin, a, b, c) over its triangles (divergence theorem), absolute value. For an
/// open mesh the figure is meaningless; see is_closed().
double enclosed_volume(const TriangleMesh& mesh);
/// Whether the surface is closed: positions that coincide are one vertex, and every edge then
/// belongs to exactly two triangles.
bool is_closed(const TriangleMesh& mesh);
/// Recomputes `normals`: per position, the area-weighted sum of its triangles' normals, normalised
/// (+z for a position in no triangle).
void compute_normals(TriangleMesh& mesh);

}  // namespace volcast
