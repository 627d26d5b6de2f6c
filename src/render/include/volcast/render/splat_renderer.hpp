#pragma once
// Point-splat rendering with OpenGL 4.5 core. Headless through EGL (Mesa's llvmpipe needs no GPU or
// display; on a GPU machine the vendor's EGL device is used), into an offscreen framebuffer that
// is read back as an image.
//
// Each point is drawn as a round splat whose screen size follows its world-space radius:
// size_px = 2 * radius_m * (viewport_height / 2) * P[1][1] / w_clip.
#include <memory>
#include <span>
#include <string>

#include "volcast/core/image.hpp"
#include "volcast/reconstruct/point_cloud.hpp"

namespace volcast {

/// A viewpoint in the world frame (metres). The default up is -y because camera frames (and so an
/// identity world_from_camera) have y pointing down.
struct ViewCamera {
  Eigen::Vector3f eye{0, 0, 0};
  Eigen::Vector3f target{0, 0, 1};
  Eigen::Vector3f up{0, -1, 0};
  float vertical_fov_deg = 60;
  float near_m = 0.05f, far_m = 100;
};

/// A viewpoint that frames all points: looks at their centroid from the side of the world origin
/// (where the cameras usually are), turned `yaw_deg` about the up axis and raised by `pitch_deg`.
ViewCamera frame_points(std::span<const PointCloud* const> clouds, float yaw_deg = 25,
                        float pitch_deg = 15);

class SplatRenderer {
 public:
  /// Creates an EGL context (no window) with an offscreen framebuffer of width x height pixels.
  /// Throws Error if EGL or OpenGL 4.5 core is unavailable, naming what failed.
  SplatRenderer(int width, int height);
  ~SplatRenderer();
  SplatRenderer(const SplatRenderer&) = delete;
  SplatRenderer& operator=(const SplatRenderer&) = delete;

  /// Renders the clouds from `view` and reads the image back into `out` (BGRA, top row first).
  /// Must be called on the thread that created the renderer.
  void render(std::span<const PointCloud* const> clouds, const ViewCamera& view, ColorImage& out);
  /// GL_RENDERER and GL_VERSION strings, e.g. "llvmpipe (LLVM 15.0.6, 256 bits), 4.5 (Core ...)".
  std::string gl_description() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
