#pragma once
// The quality table of `volcast bench --quality` and the demo's quality picture: the renderer's
// settings scored by leave-one-camera-out view synthesis (view_quality.hpp) on a registered site.
#include <filesystem>
#include <string>
#include <vector>

#include "volcast/capture/source.hpp"
#include "volcast/quality/view_quality.hpp"
#include "volcast/render/camera_renderer.hpp"

namespace volcast {

/// One row of the table: a renderer and its settings.
struct QualitySetting {
  std::string name;  ///< e.g. "splats adaptive, blend v1"; its slug names its picture
  CameraPassOptions options;
};

/// The settings compared, in the table's order. The first, "before", is the renderer's default
/// before issue 38 (adaptive splats blended with the first weights); the one named "default" is
/// CameraPassOptions{} as it is now.
std::vector<QualitySetting> quality_settings();

/// A site's cameras and one frame of each.
struct QualitySite {
  std::vector<CameraCalibration> cameras;
  std::vector<CameraFrame> frames;
  std::vector<std::string> names;
};
/// Reads `site_config` (a site config, as `volcast calibrate` writes it: each camera's source,
/// intrinsics and world_from_camera) and one frame of each source; `nominal_color` registers the
/// color of camera-folder PNGs (SourceOptions::nominal_color). Throws Error naming the file or
/// the source that cannot be read, or a camera without world_from_camera.
QualitySite load_quality_site(const std::filesystem::path& site_config,
                              const std::optional<ColorCalibration>& nominal_color = std::nullopt);

/// One setting scored.
struct QualityRow {
  std::string setting;
  ViewScore mean;  ///< each figure averaged over the held-out cameras
  std::vector<ViewScore> cameras;
  double ms_per_frame = 0;  ///< LeaveOneOut::Result::ms_per_frame
};

/// Scores each setting on `site` (logging progress). Writes into `pictures` (made if missing)
/// one side-by-side picture (side_by_side) per setting of the camera that scores worst (lowest
/// PSNR, or largest depth error without colour) under the first setting,
/// quality-<slug>.png, and quality.png: the first setting's picture above the default's. Throws
/// Error as LeaveOneOut does, or naming a picture that cannot be written.
std::vector<QualityRow> score_settings(const QualitySite& site,
                                       const std::vector<QualitySetting>& settings,
                                       const std::filesystem::path& pictures);

/// The rows as a Markdown table, with each figure's ratio to the first row where it helps.
std::string quality_table(const std::vector<QualityRow>& rows);
/// Writes {"quality": [{setting, psnr_db, ssim, depth_mean_mm, depth_p95_mm, coverage,
/// seam_energy, ms_per_frame, cameras: [...]}]} to `file`. Throws Error if it cannot be written.
void write_quality_json(const std::vector<QualityRow>& rows, const std::filesystem::path& file);

}  // namespace volcast
