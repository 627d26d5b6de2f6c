#pragma once
// Calibrating a site, the whole procedure behind `volcast calibrate`: every camera's
// world_from_camera from depth alone -- the lattice target where the cameras see it (target.hpp),
// rough start poses from a site config, targetless ICP over their overlap for the others
// (targetless.hpp) -- then the floor for the room frame (floor.hpp) and the overlap residuals.
// Positions in metres; frames as in volcast/core/calibration.hpp.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "volcast/calibrate/floor.hpp"
#include "volcast/calibrate/targetless.hpp"
#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"

namespace volcast {

/// What to calibrate and how (the flags of `volcast calibrate`).
struct CalibrationOptions {
  std::vector<std::string> sources;  ///< .mkv, image-sequence folder, camera folder or depth PNG
  std::string intrinsics_from;       ///< for a camera folder's PNGs: a .mkv or sequence folder
  std::string start;                 ///< site config with rough poses (e.g. the viewer's sliders)
  int reference = 0;                 ///< the camera whose frame is the site's (before the floor)
  bool reference_target = false;     ///< the target's first placement is the world, not a camera
  int frames = 30;                   ///< frame sets scanned for the target
  bool no_target = false;            ///< skip the target search
  bool refine = false;               ///< ICP over the overlap also for target-placed cameras
  bool no_floor = false;             ///< keep the reference camera's frame (no room alignment)
};

/// One camera of a calibrated site.
struct CalibratedCamera {
  std::string name;  ///< the source's file name, or a camera folder's serial
  std::filesystem::path source;
  std::optional<Intrinsics> intrinsics;  ///< given to the source (a camera folder's); else none
  CameraCalibration calibration;         ///< the source's; world_from_camera as placed (if so)
  std::optional<RigidTransform> world_from_camera;  ///< room frame (site frame with no_floor)
  std::string method;        ///< "target", "targetless", "start + ICP", ...; "" unplaced
  double target_rms_m = -1;  ///< RMS of the target's sphere centres; -1: not by it
  double before_rms_m = -1;  ///< overlap RMS before targetless ICP; -1: not measured
  CameraOverlap overlap;     ///< with the other placed cameras, at the final poses
  CameraFrame first;         ///< the frame the targetless step and a preview use
};

/// The result: the cameras in source order, the floor if found, and each problem as one line
/// naming its camera ("camera N: ...").
struct SiteCalibration {
  std::vector<CalibratedCamera> cameras;
  std::optional<FloorPlane> floor;  ///< set: the world is the room frame (floor at y = 0)
  std::vector<std::string> problems;
  size_t placed() const;  ///< cameras with a world_from_camera
};

/// Opens the sources, scans up to `frames` frame sets for the target, solves it, adds the start
/// poses, registers the cameras still unplaced (all with `refine`) over their overlap, and finds
/// the floor; logs each step. A camera that cannot be placed is a problem, not an error. Throws
/// Error for no sources, a `reference` out of range (naming "--reference N") or a source that
/// cannot be opened (naming it).
SiteCalibration calibrate_site(const CalibrationOptions& options);

/// The report `volcast calibrate` prints: one row per camera (name, method, target RMS, overlap,
/// RMS before and after, height) and a legend.
std::string calibration_table(const SiteCalibration& site);

/// Writes the site config (volcast/io/site_config.hpp) to `out`: sources relative to its folder
/// where they stay near it, else absolute; poses and how they were found. Throws Error naming the
/// file when it cannot be written.
void write_calibrated_site(const SiteCalibration& site, const std::filesystem::path& out);

/// What `volcast calibrate` does with the result: prints calibration_table on stdout, logs each
/// problem, writes the site config to `out` and, unless `preview` is empty, the placed cameras'
/// preview PNG there (preview.hpp). Returns the exit code: 0 when every camera was placed, 3 when
/// some were not (the file holds the others). Throws Error when a file cannot be written.
int report_calibration(const SiteCalibration& site, const std::filesystem::path& out,
                       const std::string& preview);

}  // namespace volcast
