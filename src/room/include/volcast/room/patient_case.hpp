#pragma once
// The patient case in the virtual OR as plain data (Fischer et al. 2024, §3.4: organ models every
// participant can grab and inspect; a virtual monitor with medical images): its grabbable objects'
// meshes, its CT series, what the monitor shows, and the monitor's picture. The assets library
// builds it from a case folder (assets/shared_case.hpp), the session sends it (session/objects.hpp
// writes its wire format: message 0x4b, 0x4d) and the renderer draws it (render/case_renderer.hpp).
// Room frame as room.hpp's: metres, y up.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "volcast/room/room.hpp"

namespace volcast {

/// One coloured surface of an object.
struct SharedPart {
  std::string name;
  Eigen::Vector4f rgba{1, 1, 1, 1};        ///< linear RGB 0..1, alpha = opacity
  std::vector<Eigen::Vector3f> positions;  ///< metres, object frame
  std::vector<Eigen::Vector3f> normals;    ///< unit, one per position
  std::vector<uint32_t> indices;           ///< 3 per triangle
};

/// A grabbable object: parts that move together, placed in the room by room_from_object.
struct SharedObject {
  std::string name;
  Pose rest;  ///< room_from_object when the case is loaded
  std::vector<SharedPart> parts;
  float radius_m = 0;  ///< the smallest sphere about the object's origin holding every vertex
};

/// A CT series for the monitor (dicom.hpp's, as sent).
struct MonitorSeries {
  int width = 0, height = 0, slices = 0;
  Eigen::Vector3f spacing_mm = Eigen::Vector3f::Ones();
  std::vector<int16_t> hu;       ///< slices x height x width
  std::vector<uint8_t> overlay;  ///< same layout, 0/1; empty without one
  std::string overlay_label;
};

/// The case every participant sees: its objects and, when it has one, the monitor's CT series.
struct SharedCase {
  uint32_t generation = 0;  ///< bumped by the server each time it swaps the case
  std::string name;
  std::vector<SharedObject> objects;
  std::optional<MonitorSeries> monitor;
};

/// What the monitor shows: a slice of the case's series, in a window, with or without the overlay.
struct MonitorState {
  uint32_t generation = 0;         ///< the case's it belongs to
  uint16_t slice = 0;              ///< < the series' slices
  float center = 40, width = 400;  ///< window, HU
  bool overlay = true;
  uint32_t by = 0;  ///< participant who set it (0: the server)
};

/// A window preset (width/center in HU), as OHIF Viewer ships them: abdomen (soft tissue)
/// 400/40, liver 150/90, bone 2500/480.
struct WindowPreset {
  const char* name;
  float center, width;
};
const std::vector<WindowPreset>& window_presets();
/// The preset called `name`. Throws Error listing the names.
WindowPreset window_preset(const std::string& name);

/// The gray level 0..255 of `hu` in the window (center c, width w, HU): DICOM's linear VOI LUT
/// function (PS3.3 C.11.2.1.2.1) with output 0..255: 0 for hu <= c - 0.5 - (w - 1) / 2, 255 for
/// hu > c - 0.5 + (w - 1) / 2, else ((hu - (c - 0.5)) / (w - 1) + 0.5) * 255 rounded. w < 1 is 1.
uint8_t window_gray(float hu, float center, float width);

/// What the monitor shows: slice `state.slice` as RGBA8 (width x height, row 0 at the top), the
/// window's gray, where the overlay is (when state.overlay) mixed 40 % towards orange. Throws
/// Error if the slice is out of range.
std::vector<uint8_t> monitor_image(const MonitorSeries& series, const MonitorState& state);

}  // namespace volcast
