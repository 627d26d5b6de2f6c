#pragma once
// Label volumes (segmentations stored as one integer label per voxel) and the surfaces of their
// labels, extracted at load time: VTK's discrete flying edges (a marching-cubes variant for label
// images; Schroeder et al. 2015), windowed-sinc smoothing (Taubin et al. 1996, low shrinkage), and
// quadric decimation to a triangle budget -- the pipeline 3D Slicer uses to make models from
// segmentations.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

#include "volcast/assets/mesh.hpp"

namespace volcast {

/// A label volume: dims[0] x dims[1] x dims[2] voxels, x fastest. Voxel (i, j, k) has its centre
/// at origin_mm + (i, j, k) .* spacing_mm in the case frame (millimetres).
struct LabelVolume {
  int dims[3] = {0, 0, 0};
  Eigen::Vector3d origin_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d spacing_mm = Eigen::Vector3d::Ones();
  std::vector<int32_t> labels;
  double voxel_volume_mm3() const { return spacing_mm.prod(); }
  size_t index(int i, int j, int k) const {
    return (static_cast<size_t>(k) * dims[1] + j) * dims[0] + i;
  }
};

/// Reads a VTK XML image (.vti) whose first point-data array holds integer labels. Throws Error
/// naming the file if it cannot be read, is not an image, has no integer scalars, or holds more
/// than 2^30 voxels.
LabelVolume read_label_volume(const std::filesystem::path& path);

/// Which labels belong to a structure. 3D-IRCADb stores structures as bit flags, so a structure is
/// "label & mask == value" (liver: mask = value = 448; tumours: mask = value = 2 ...).
struct LabelSelector {
  int32_t mask = -1;
  int32_t value = 1;
  bool operator()(int32_t label) const { return (label & mask) == value; }
};

/// A structure as a binary voxel mask (1 inside), same grid as the volume.
std::vector<uint8_t> select(const LabelVolume& volume, const LabelSelector& selector);

/// A box of a volume's voxels: `lo` the first voxel inside, `hi` one past the last, voxel indices
/// (i, j, k) of the volume's grid.
struct VoxelBox {
  std::array<int, 3> lo{0, 0, 0};
  std::array<int, 3> hi{0, 0, 0};
  int size(int axis) const { return hi[axis] - lo[axis]; }
  bool empty() const { return size(0) <= 0 || size(1) <= 0 || size(2) <= 0; }
  size_t voxels() const { return empty() ? 0 : static_cast<size_t>(size(0)) * size(1) * size(2); }
  /// Where the volume's voxel (i, j, k), inside the box, is in a mask over the box (x fastest).
  size_t index(int i, int j, int k) const {
    return (static_cast<size_t>(k - lo[2]) * size(1) + (j - lo[1])) * size(0) + (i - lo[0]);
  }
};

/// A structure as a binary mask over the smallest box of the volume's grid that holds it: a
/// tumour of a few hundred voxels is not a copy of the whole CT's grid.
struct MaskComponent {
  VoxelBox box;
  std::vector<uint8_t> mask;  ///< box.voxels() bytes, x fastest: 1 inside the structure
  size_t voxels = 0;          ///< how many are 1
};

/// A whole-grid mask cut to the smallest box holding its 1 voxels (an empty box and mask when it
/// has none). Throws Error if the mask does not match the volume's grid.
MaskComponent crop_to_box(const LabelVolume& grid, const std::vector<uint8_t>& mask);

/// A structure over the smallest box of the volume's grid that holds it: the same as
/// crop_to_box(grid, select(volume, selector)), without a mask of the whole grid (one pass over the
/// labels for the box, then one over the box). Throws Error if the labels do not fill the grid.
MaskComponent select_box(const LabelVolume& volume, const LabelSelector& selector);

/// The mask's 6-connected components of at least `min_voxels` voxels, largest first, each over
/// its own box. Throws Error if the mask does not match the volume's grid.
std::vector<MaskComponent> connected_components(const LabelVolume& grid,
                                                const std::vector<uint8_t>& mask,
                                                size_t min_voxels = 1);
/// The same for a structure over its box (select_box, crop_to_box): the flood fill only visits
/// that box; each component's box is in the volume's voxel indices. Throws Error if the mask does
/// not fill the box.
std::vector<MaskComponent> connected_components(const MaskComponent& structure,
                                                size_t min_voxels = 1);

struct SurfaceOptions {
  int smoothing_iterations = 20;  ///< windowed sinc; 0: none
  double pass_band = 0.1;         ///< windowed sinc pass band (0..2; smaller smooths more)
  size_t max_triangles = 60000;   ///< decimated down to at most this many (0: no limit)
};

/// The closed surface of the voxels where mask == 1 (voxel centres' grid padded by one empty voxel
/// on every side, so structures touching the volume's border are closed too), in the case frame,
/// millimetres, triangles facing outward, smooth normals. Empty when the mask is. Throws Error if
/// the mask does not match the volume's grid.
TriangleMesh extract_surface(const LabelVolume& grid, const std::vector<uint8_t>& mask,
                             const SurfaceOptions& options = {});
/// The same for a structure over its box (crop_to_box, connected_components): the surface only
/// visits the box (padded by one empty voxel), in the volume's case frame. Throws Error if the
/// box is not inside the grid or the mask does not fill the box.
TriangleMesh extract_surface(const LabelVolume& grid, const MaskComponent& structure,
                             const SurfaceOptions& options = {});

}  // namespace volcast
