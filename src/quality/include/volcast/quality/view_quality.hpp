#pragma once
// The picture, measured: leave-one-camera-out view synthesis (issue 38). For each camera k of a
// registered site, the other cameras are drawn from camera k's exact viewpoint (its intrinsics,
// lens model undone, and world_from_camera) and compared with what camera k really measured.
// This is the evaluation of free-viewpoint RGB-D rendering by held-out views used across the
// field (e.g. BlendPCR, Mühlenbrock et al., ICAT-EGVE 2024, §5); the seam measure is ours.
//
// Every image here is camera k's undistorted pinhole (make_pixel_map(k, true, ...): its fx, fy,
// cx, cy, its size), top row first.
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/core/image.hpp"
#include "volcast/render/camera_renderer.hpp"

namespace volcast {

/// One held-out view: what the others drew and what the camera saw, pixel for pixel.
struct ViewImages {
  ColorImage rendered;                  ///< BGRA as drawn (the clear colour where nothing was)
  std::vector<float> rendered_depth_m;  ///< along the optical axis, metres; 0 = nothing drawn
  /// Per pixel, the camera (index into the site) with the largest share of the blended colour
  /// (the nearest one without blending); kNoSource where nothing was drawn.
  std::vector<uint8_t> source;
  DepthImage real_depth;  ///< mm, 0 = invalid
  ColorImage real_color;  ///< BGRA; empty when the camera has no colour
};
inline constexpr uint8_t kNoSource = 255;

/// The score of one held-out view. Over "compared" pixels: drawn, and valid in the real depth
/// (and with real colour, for the colour figures).
struct ViewScore {
  double psnr_db = 0;  ///< colour, RGB 0..255, over compared pixels; 99 when identical
  /// Colour SSIM (Wang et al. 2004) of luma (BT.601), FFmpeg's ssim filter (libavfilter: 8x8
  /// windows on a 4x4 grid), with the pixels not compared taken from the real image in both;
  /// then rescaled to the compared share: 1 - (1 - s) * pixels / compared.
  double ssim = 0;
  double depth_mean_mm = 0;  ///< |rendered - real| depth over compared pixels, mm
  double depth_p95_mm = 0;   ///< its 95th percentile, mm
  double coverage = 0;       ///< compared / the real camera's valid pixels, 0..1
  /// Mean squared luma gradient (central differences, 0..255 units squared) of the rendered
  /// picture over seam pixels: drawn pixels with a 4-neighbour whose dominant source differs.
  double seam_energy = 0;
  /// The same over the seam pixels where the real camera measured the pixel and its
  /// 4-neighbours, of the colour error's luma (rendered - real): the steps along seams that the
  /// real picture does not have (its own edges and texture cancel out).
  double seam_error_energy = 0;
  size_t valid = 0;        ///< the real camera's valid depth pixels
  size_t compared = 0;     ///< drawn and valid
  size_t seam_pixels = 0;  ///< pixels the seam energy averages over
};

/// Scores `v`. Throws Error if its images differ in size.
ViewScore score_view(const ViewImages& v);

/// SSIM of the luma of two BGRA images of one size, 0..1 (1: identical), through libavfilter's
/// ssim filter. Throws Error if the sizes differ or FFmpeg fails (naming the step).
double ssim_luma(const ColorImage& a, const ColorImage& b);

/// The picture a person compares by eye, four panels of the view's size left to right: rendered,
/// real, colour error (|rendered - real| summed over RGB, black 0 .. white >= 96), depth error
/// (green 0 mm .. yellow 25 .. red >= 50 mm). Pixels the real camera measured but nothing was
/// drawn on are magenta in both error panels; pixels it did not measure are dark.
ColorImage side_by_side(const ViewImages& v);

/// Draws a site's cameras leaving one out at a time, headless (its own EGL context, current on
/// the constructing thread, made once), into targets of each camera's size.
class LeaveOneOut {
 public:
  /// `cameras`: the site's calibrations (world_from_camera set, any lens model; every camera the
  /// same size); `frames`: one frame per camera, depth mm at the calibration's size, colour
  /// registered to it or empty. Undistorts each camera's real images once. Throws Error if the
  /// counts differ, there are under 2 or over 64 cameras, sizes differ, or OpenGL fails.
  LeaveOneOut(std::vector<CameraCalibration> cameras, std::vector<CameraFrame> frames);
  ~LeaveOneOut();
  LeaveOneOut(const LeaveOneOut&) = delete;
  LeaveOneOut& operator=(const LeaveOneOut&) = delete;

  struct Result {
    std::vector<ViewImages> views;  ///< per held-out camera
    std::vector<ViewScore> scores;  ///< per held-out camera
    double ms_per_frame = 0;        ///< median draw of the others into one view (glFinish)
  };
  /// Each camera held out in turn, the rest drawn with `options` (its per-camera visibility is
  /// replaced; its tints are kept). Throws Error as CameraRenderer::draw_cameras does.
  Result run(const CameraPassOptions& options);

  /// Moves camera `camera` (a test's deliberate misregistration). Throws Error if out of range.
  void set_world_from_camera(size_t camera, const RigidTransform& world_from_camera);
  size_t camera_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
