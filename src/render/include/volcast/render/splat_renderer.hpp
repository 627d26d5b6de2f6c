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

/// A viewpoint that orbits a pivot starting from a camera: the pivot lies on the camera's optical
/// axis at the median depth of the points; the eye starts at `world_from_camera`'s origin and is
/// turned `yaw_deg` about the camera's up axis and `pitch_deg` about its right axis, around the
/// pivot, looking at it. Shows the scene roughly as that camera saw it, but from the side, so
/// depth is visible.
ViewCamera orbit_view(const RigidTransform& world_from_camera,
                      std::span<const PointCloud* const> clouds, float yaw_deg = 20,
                      float pitch_deg = 10);

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
