#pragma once
// A patient case for the virtual OR (Fischer et al. 2024, §3.4: organ models from real patient
// data, a half-transparent shell, quickly replaceable for a new case): a folder of organ meshes
// and/or label volumes (turned into meshes at load time) and/or a DICOM series for the monitor.
//
// case.json (optional; paths relative to the folder):
//   {"name": "IRCAD patient 11",
//    "orientation": "lps",          // the case frame: "lps" (DICOM patient frame: x to the
//                                   // patient's left, y posterior, z head; default) or "room"
//    "max_triangles": 60000,        // per part, decimated to at most this (default 60000)
//    "parts": [
//      {"name": "liver", "mesh": "liver.obj",                 // a mesh file (Assimp), mm
//       "color": [0.55, 0.18, 0.12], "opacity": 1.0,          // linear RGB 0..1, 0..1
//       "group": "liver"},                                    // parts of a group move together
//      {"name": "tumour", "labels": "seg.vti", "mask": 2, "value": 2,   // label & mask == value
//       "components": true, "min_voxels": 10, ...}],          // one part per connected component,
//                                                             // named "tumour 1", "tumour 2", ...
//    "dicom": {"series": "ct", "seg": "ct/seg.dcm", "segment": "Liver"}}   // optional
// Without case.json every mesh file (.obj .stl .ply .gltf .glb .off .dae) is a part named after
// its file, every .vti label volume gives 3D-IRCADb's structures (bit flags: liver 448, tumours
// bit 2 one part per component, portal vein bit 16, hepatic veins bit 32), and DICOM images in the
// folder (or its first subfolder that has some) are the series, a SEG among them its overlay.
// Parts named liver, porta/portal, hepatic, cava, tumour or gallbladder are then the group
// "liver", the others "body". Colours and opacities come from the part's name (liver,
// portal/porta, cava/hepatic/venous, aorta/artery, tumour, gallbladder, kidney, bone, skin; the
// liver is a half-transparent shell over its vessels and tumours, the skin more transparent).
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "volcast/assets/dicom.hpp"
#include "volcast/assets/mesh.hpp"

namespace volcast {

struct CasePart {
  std::string name, group;
  std::filesystem::path source;  ///< the file it came from
  TriangleMesh mesh;             ///< case frame, millimetres
  Eigen::Vector4f rgba{0.8f, 0.8f, 0.8f, 1.0f};
  double volume_ml = 0;  ///< enclosed volume of the mesh (meaningless unless closed)
  bool closed = false;
  size_t voxels = 0;           ///< label parts: voxels of the structure; 0 for mesh files
  double voxel_volume_ml = 0;  ///< label parts: voxels x voxel volume
  BoundingBox bbox_mm;
};

struct Case {
  std::string name;
  std::filesystem::path folder;
  std::vector<CasePart> parts;
  std::optional<DicomSeries> dicom;
  /// room_from_case's rotation (the case frame's axes in the room: y up; the patient lies along
  /// the operating table's x axis, head at -x, face up). Translation is set by the session.
  Eigen::Matrix3f room_from_case = Eigen::Matrix3f::Identity();
  double load_ms = 0;
  std::vector<std::string> groups() const;  ///< in order of first appearance
};

/// The most parts a case may have (case.json's "parts", label components, mesh files in a
/// folder): a real case has tens; a session shares at most 64 objects of 256 parts
/// (session/objects.hpp). Checked before any file is read, so a hostile case.json costs nothing.
inline constexpr size_t kMaxCaseParts = 256;
/// The largest case.json read (bytes): 256 parts take tens of kilobytes.
inline constexpr uintmax_t kMaxCaseJsonBytes = 1u << 20;
/// The largest "max_triangles" (per part) case.json may ask for.
inline constexpr size_t kMaxPartTriangles = 1'000'000;

struct CaseLoadOptions {
  size_t max_triangles = 60000;  ///< per part unless case.json says otherwise
  /// Called with what is being loaded ("liver.obj", "labels: liver") before each step.
  std::function<void(const std::string&)> progress;
};

/// Loads the case in `folder`. Throws Error naming the folder and what was wrong: no such
/// folder, a case.json that does not parse or names a missing file or an unknown field value, a
/// file that does not read, a folder with nothing a case can hold, a case.json over
/// kMaxCaseJsonBytes, more than kMaxCaseParts parts or a "max_triangles" over kMaxPartTriangles
/// (these before any other file is read).
Case load_case(const std::filesystem::path& folder, const CaseLoadOptions& options = {});

/// The default colour of a part called `name` (see the top of this file).
Eigen::Vector4f default_part_rgba(const std::string& name);

/// The case as JSON: {"name", "load_ms", "parts": [{"name", "group", "triangles", "volume_ml",
/// "closed", "bbox_mm": [[min], [max]], "voxels"?, "voxel_volume_ml"?}], "dicom"?: {"slices",
/// "width", "height", "spacing_mm": [x, y, z], "overlay"?: label}}.
std::string case_json(const Case& c);

}  // namespace volcast
