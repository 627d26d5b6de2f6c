#include "volcast/assets/label_volume.hpp"

#include <vtkCellArray.h>
#include <vtkDataArray.h>
#include <vtkDiscreteFlyingEdges3D.h>
#include <vtkIdTypeArray.h>
#include <vtkImageConnectivityFilter.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkPolyDataNormals.h>
#include <vtkQuadricDecimation.h>
#include <vtkTriangleFilter.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowedSincPolyDataFilter.h>
#include <vtkXMLImageDataReader.h>

#include <algorithm>
#include <iterator>
#include <numeric>

#include "volcast/core/error.hpp"

namespace volcast {

namespace {

void check_grid(const LabelVolume& grid, const std::vector<uint8_t>& mask, const char* what) {
  if (mask.size() != static_cast<size_t>(grid.dims[0]) * grid.dims[1] * grid.dims[2])
    throw Error(std::string(what) + ": the mask does not match the volume's grid");
}

// The structure as a VTK image over its box padded by one empty voxel on every side; the image's
// origin puts each voxel where it is in the volume's case frame.
vtkNew<vtkImageData> padded_image(const LabelVolume& grid, const MaskComponent& s) {
  const VoxelBox& box = s.box;
  for (int a = 0; a < 3; ++a)
    if (box.lo[a] < 0 || box.hi[a] > grid.dims[a])
      throw Error("surface: the structure's box is not inside the volume's grid");
  if (s.mask.size() != box.voxels())
    throw Error("surface: the structure's mask does not fill its box");
  const int nx = box.size(0), ny = box.size(1), nz = box.size(2);
  vtkNew<vtkImageData> image;
  image->SetDimensions(nx + 2, ny + 2, nz + 2);
  image->SetSpacing(grid.spacing_mm.data());
  const Eigen::Vector3d origin =
      grid.origin_mm + (Eigen::Vector3d(box.lo[0], box.lo[1], box.lo[2]) - Eigen::Vector3d::Ones())
                           .cwiseProduct(grid.spacing_mm);
  image->SetOrigin(origin.data());
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  auto* out = static_cast<uint8_t*>(image->GetScalarPointer());
  std::fill_n(out, static_cast<size_t>(nx + 2) * (ny + 2) * (nz + 2), uint8_t{0});
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      std::copy_n(s.mask.data() + (static_cast<size_t>(k) * ny + j) * nx, nx,
                  out + ((static_cast<size_t>(k + 1) * (ny + 2) + j + 1) * (nx + 2) + 1));
  return image;
}

TriangleMesh to_mesh(vtkPolyData* poly) {
  TriangleMesh mesh;
  const vtkIdType points = poly->GetNumberOfPoints();
  mesh.positions.resize(points);
  for (vtkIdType i = 0; i < points; ++i) {
    double p[3];
    poly->GetPoint(i, p);
    mesh.positions[i] = Eigen::Vector3d(p[0], p[1], p[2]).cast<float>();
  }
  vtkCellArray* polys = poly->GetPolys();
  mesh.indices.reserve(static_cast<size_t>(polys->GetNumberOfCells()) * 3);
  const vtkIdType* ids = nullptr;
  vtkIdType count = 0;
  for (polys->InitTraversal(); polys->GetNextCell(count, ids);)
    if (count == 3)
      for (int i = 0; i < 3; ++i) mesh.indices.push_back(static_cast<uint32_t>(ids[i]));
  if (vtkDataArray* normals = poly->GetPointData()->GetNormals();
      normals && normals->GetNumberOfTuples() == points) {
    mesh.normals.resize(points);
    for (vtkIdType i = 0; i < points; ++i) {
      double n[3];
      normals->GetTuple(i, n);
      mesh.normals[i] = Eigen::Vector3d(n[0], n[1], n[2]).cast<float>();
    }
  } else {
    compute_normals(mesh);
  }
  return mesh;
}

}  // namespace

LabelVolume read_label_volume(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error("label volume " + path.string() + ": no such file");
  vtkNew<vtkXMLImageDataReader> reader;
  if (!reader->CanReadFile(path.string().c_str()))
    throw Error("label volume " + path.string() + ": not a VTK XML image (.vti)");
  reader->SetFileName(path.string().c_str());
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  vtkDataArray* scalars = image ? image->GetPointData()->GetScalars() : nullptr;
  if (!scalars && image && image->GetPointData()->GetNumberOfArrays() > 0)
    scalars = image->GetPointData()->GetArray(0);
  if (!scalars) throw Error("label volume " + path.string() + ": no point data in it");
  const int type = scalars->GetDataType();
  const bool integral = type == VTK_CHAR || type == VTK_SIGNED_CHAR || type == VTK_UNSIGNED_CHAR ||
                        type == VTK_SHORT || type == VTK_UNSIGNED_SHORT || type == VTK_INT ||
                        type == VTK_UNSIGNED_INT || type == VTK_LONG || type == VTK_UNSIGNED_LONG ||
                        type == VTK_LONG_LONG || type == VTK_UNSIGNED_LONG_LONG;
  if (!integral || scalars->GetNumberOfComponents() != 1)
    throw Error("label volume " + path.string() + ": its scalars are not one integer per voxel");
  LabelVolume v;
  image->GetDimensions(v.dims);
  const uint64_t n = static_cast<uint64_t>(v.dims[0]) * v.dims[1] * v.dims[2];
  if (v.dims[0] < 1 || v.dims[1] < 1 || v.dims[2] < 1 || n > (uint64_t{1} << 30) ||
      static_cast<uint64_t>(scalars->GetNumberOfTuples()) != n)
    throw Error("label volume " + path.string() + ": dimensions " + std::to_string(v.dims[0]) +
                "x" + std::to_string(v.dims[1]) + "x" + std::to_string(v.dims[2]) +
                " do not fit its data");
  image->GetOrigin(v.origin_mm.data());
  image->GetSpacing(v.spacing_mm.data());
  if (!v.spacing_mm.allFinite() || (v.spacing_mm.array() <= 0).any() || !v.origin_mm.allFinite())
    throw Error("label volume " + path.string() + ": spacing or origin is not positive and finite");
  v.labels.resize(n);
  for (uint64_t i = 0; i < n; ++i) v.labels[i] = static_cast<int32_t>(scalars->GetTuple1(i));
  return v;
}

std::vector<uint8_t> select(const LabelVolume& volume, const LabelSelector& selector) {
  std::vector<uint8_t> mask(volume.labels.size());
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = selector(volume.labels[i]) ? 1 : 0;
  return mask;
}

MaskComponent crop_to_box(const LabelVolume& grid, const std::vector<uint8_t>& mask) {
  check_grid(grid, mask, "crop");
  const int nx = grid.dims[0], ny = grid.dims[1], nz = grid.dims[2];
  MaskComponent out;
  VoxelBox& box = out.box;
  box.lo = {nx, ny, nz};
  box.hi = {0, 0, 0};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j) {
      const uint8_t* row = mask.data() + grid.index(0, j, k);
      const uint8_t* first = std::find(row, row + nx, uint8_t{1});
      if (first == row + nx) continue;
      const uint8_t* last = std::find(std::make_reverse_iterator(row + nx),
                                      std::make_reverse_iterator(row), uint8_t{1})
                                .base() -
                            1;
      box.lo = {std::min(box.lo[0], static_cast<int>(first - row)), std::min(box.lo[1], j),
                std::min(box.lo[2], k)};
      box.hi = {std::max(box.hi[0], static_cast<int>(last - row) + 1), std::max(box.hi[1], j + 1),
                std::max(box.hi[2], k + 1)};
    }
  if (box.empty()) return MaskComponent{};
  out.mask.resize(box.voxels());
  for (int k = box.lo[2]; k < box.hi[2]; ++k)
    for (int j = box.lo[1]; j < box.hi[1]; ++j) {
      const uint8_t* row = mask.data() + grid.index(box.lo[0], j, k);
      uint8_t* dst = out.mask.data() + box.index(box.lo[0], j, k);
      for (int i = 0; i < box.size(0); ++i) {
        dst[i] = row[i] == 1;
        out.voxels += dst[i];
      }
    }
  return out;
}

MaskComponent select_box(const LabelVolume& volume, const LabelSelector& selector) {
  const int nx = volume.dims[0], ny = volume.dims[1], nz = volume.dims[2];
  if (volume.labels.size() != static_cast<size_t>(nx) * ny * nz)
    throw Error("select: the labels do not fill the volume's grid");
  MaskComponent out;
  VoxelBox& box = out.box;
  box.lo = {nx, ny, nz};
  box.hi = {0, 0, 0};
  // One pass over the labels for the box (each row's first and last selected voxel), then the mask
  // over the box only: no whole-grid mask is made.
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j) {
      const int32_t* row = volume.labels.data() + volume.index(0, j, k);
      int first = 0;
      while (first < nx && !selector(row[first])) ++first;
      if (first == nx) continue;
      int last = nx - 1;
      while (!selector(row[last])) --last;
      box.lo = {std::min(box.lo[0], first), std::min(box.lo[1], j), std::min(box.lo[2], k)};
      box.hi = {std::max(box.hi[0], last + 1), std::max(box.hi[1], j + 1),
                std::max(box.hi[2], k + 1)};
    }
  if (box.empty()) return MaskComponent{};
  out.mask.resize(box.voxels());
  for (int k = box.lo[2]; k < box.hi[2]; ++k)
    for (int j = box.lo[1]; j < box.hi[1]; ++j) {
      const int32_t* row = volume.labels.data() + volume.index(box.lo[0], j, k);
      uint8_t* dst = out.mask.data() + box.index(box.lo[0], j, k);
      for (int i = 0; i < box.size(0); ++i) {
        dst[i] = selector(row[i]) ? 1 : 0;
        out.voxels += dst[i];
      }
    }
  return out;
}

std::vector<MaskComponent> connected_components(const MaskComponent& structure, size_t min_voxels) {
  const VoxelBox& whole = structure.box;
  if (structure.mask.size() != whole.voxels())
    throw Error("components: the structure's mask does not fill its box");
  const int nx = whole.size(0), ny = whole.size(1), nz = whole.size(2);
  const std::vector<uint8_t>& mask = structure.mask;
  // Flood fill with an explicit stack (6-connectivity) over the structure's box; each component's
  // size and box (in the box's own voxel indices until the end).
  std::vector<uint32_t> label(mask.size(), 0);
  std::vector<size_t> sizes{0};
  std::vector<VoxelBox> boxes{VoxelBox{}};
  std::vector<size_t> stack;
  const auto at_index = [&](int a, int b, int c) {
    return (static_cast<size_t>(c) * ny + b) * nx + a;
  };
  for (size_t start = 0; start < mask.size(); ++start) {
    if (!mask[start] || label[start]) continue;
    const auto id = static_cast<uint32_t>(sizes.size());
    size_t count = 0;
    VoxelBox box{{nx, ny, nz}, {0, 0, 0}};
    stack.push_back(start);
    label[start] = id;
    while (!stack.empty()) {
      const size_t at = stack.back();
      stack.pop_back();
      ++count;
      const int i = static_cast<int>(at % nx), j = static_cast<int>((at / nx) % ny),
                k = static_cast<int>(at / (static_cast<size_t>(nx) * ny));
      box.lo = {std::min(box.lo[0], i), std::min(box.lo[1], j), std::min(box.lo[2], k)};
      box.hi = {std::max(box.hi[0], i + 1), std::max(box.hi[1], j + 1), std::max(box.hi[2], k + 1)};
      const auto visit = [&](int a, int b, int c) {
        if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz) return;
        const size_t n = at_index(a, b, c);
        if (mask[n] && !label[n]) label[n] = id, stack.push_back(n);
      };
      visit(i - 1, j, k), visit(i + 1, j, k), visit(i, j - 1, k), visit(i, j + 1, k);
      visit(i, j, k - 1), visit(i, j, k + 1);
    }
    sizes.push_back(count);
    boxes.push_back(box);
  }
  std::vector<uint32_t> order;
  for (uint32_t id = 1; id < sizes.size(); ++id)
    if (sizes[id] >= min_voxels) order.push_back(id);
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return sizes[a] > sizes[b]; });
  std::vector<MaskComponent> out(order.size());
  for (size_t s = 0; s < order.size(); ++s) {
    const uint32_t id = order[s];
    const VoxelBox& local = boxes[id];
    MaskComponent& c = out[s];
    c.voxels = sizes[id];
    for (int a = 0; a < 3; ++a) {  // the box's voxel indices -> the volume's
      c.box.lo[a] = local.lo[a] + whole.lo[a];
      c.box.hi[a] = local.hi[a] + whole.lo[a];
    }
    c.mask.assign(c.box.voxels(), 0);
    for (int k = local.lo[2]; k < local.hi[2]; ++k)
      for (int j = local.lo[1]; j < local.hi[1]; ++j) {
        const uint32_t* row = label.data() + at_index(local.lo[0], j, k);
        uint8_t* dst = c.mask.data() + local.index(local.lo[0], j, k);
        for (int i = 0; i < local.size(0); ++i) dst[i] = row[i] == id;
      }
  }
  return out;
}

std::vector<MaskComponent> connected_components(const LabelVolume& grid,
                                                const std::vector<uint8_t>& mask,
                                                size_t min_voxels) {
  check_grid(grid, mask, "components");
  return connected_components(crop_to_box(grid, mask), min_voxels);
}

TriangleMesh extract_surface(const LabelVolume& grid, const std::vector<uint8_t>& mask,
                             const SurfaceOptions& options) {
  return extract_surface(grid, crop_to_box(grid, mask), options);
}

TriangleMesh extract_surface(const LabelVolume& grid, const MaskComponent& structure,
                             const SurfaceOptions& options) {
  if (structure.box.empty() && structure.mask.empty()) return {};
  vtkNew<vtkImageData> image = padded_image(grid, structure);
  if (std::none_of(structure.mask.begin(), structure.mask.end(), [](uint8_t m) { return m != 0; }))
    return {};
  vtkNew<vtkDiscreteFlyingEdges3D> surface;
  surface->SetInputData(image);
  surface->SetValue(0, 1);
  surface->ComputeNormalsOff();
  surface->ComputeGradientsOff();
  surface->ComputeScalarsOff();
  vtkAlgorithm* last = surface;
  vtkNew<vtkWindowedSincPolyDataFilter> smooth;
  if (options.smoothing_iterations > 0) {
    smooth->SetInputConnection(last->GetOutputPort());
    smooth->SetNumberOfIterations(options.smoothing_iterations);
    smooth->SetPassBand(options.pass_band);
    smooth->BoundarySmoothingOff();
    smooth->FeatureEdgeSmoothingOff();
    smooth->NonManifoldSmoothingOn();
    smooth->NormalizeCoordinatesOn();
    last = smooth;
  }
  last->Update();
  auto* poly = vtkPolyData::SafeDownCast(last->GetOutputDataObject(0));
  vtkNew<vtkQuadricDecimation> decimate;
  if (options.max_triangles > 0 && poly &&
      static_cast<size_t>(poly->GetNumberOfPolys()) > options.max_triangles) {
    decimate->SetInputConnection(last->GetOutputPort());
    decimate->SetTargetReduction(1.0 - static_cast<double>(options.max_triangles) /
                                           static_cast<double>(poly->GetNumberOfPolys()));
    decimate->VolumePreservationOn();
    last = decimate;
  }
  vtkNew<vtkPolyDataNormals> normals;
  normals->SetInputConnection(last->GetOutputPort());
  normals->SplittingOff();  // one normal per point: the surface stays welded (closed)
  normals->ConsistencyOn();
  normals->AutoOrientNormalsOn();  // outward, and the triangles turned to match
  normals->Update();
  return to_mesh(normals->GetOutput());
}

}  // namespace volcast
