#pragma once
// The splat pass: draws point clouds as round splats, with OpenGL 4.5 core, into a RenderTarget it
// is given. It creates no context and no framebuffer and reads nothing back; the caller supplies
// a current context (a window's, an OpenXR session's, or a HeadlessTarget's) and decides if and
// when pixels are read (HeadlessTarget::read_image).
//
// Each point is drawn as a round splat whose screen size follows its world-space radius:
// size_px = 2 * radius_m * (viewport_height / 2) * clip_from_view(1, 1) / w_clip,
// clamped to 1..64 pixels.
//
// Two sources of points: point clouds built on the CPU (draw), or the cameras' images themselves
// (draw_cameras: GPU reconstruction, the paper's path and the live viewer's). There, each camera's
// depth (R16UI, mm) and color (RGBA8) are uploaded as textures once per frame and one draw per
// camera runs a vertex per depth pixel: the vertex shader reads the pixel's depth z (metres) and
// its ray (X/Z, Y/Z) from the camera's ray table (make_ray_table: lens model included; RG32F,
// uploaded once) and places the point at world_from_camera * (ray.x * z, ray.y * z, z) with
// radius z * splat_radius_per_metre(intrinsics) -- the same points CloudBuilder makes, with no
// per-point CPU work.
#include <memory>
#include <span>
#include <string>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/reconstruct/avatar_filter.hpp"
#include "volcast/reconstruct/point_cloud.hpp"
#include "volcast/render/render_target.hpp"
#include "volcast/render/view.hpp"

namespace volcast {

class SplatRenderer {
 public:
  /// Builds the splat program and vertex buffers in the OpenGL context current on the calling
  /// thread; every later call must be made with that context current. Throws Error if no context
  /// is current, it is older than OpenGL 4.5, or the shaders do not compile or link.
  SplatRenderer();
  /// Deletes the GL objects; the same context must still be current.
  ~SplatRenderer();
  SplatRenderer(const SplatRenderer&) = delete;
  SplatRenderer& operator=(const SplatRenderer&) = delete;

  /// Clears the target's viewport (colour to dark grey-blue, depth to far) and draws every point
  /// of `clouds` (world frame) as seen through `view`. Touches no pixel outside the viewport.
  /// Leaves `target.framebuffer` bound for drawing and the scissor test disabled. Throws Error if
  /// the viewport is empty, the framebuffer is not complete, or OpenGL reports an error.
  void draw(std::span<const PointCloud* const> clouds, const View& view,
            const RenderTarget& target);

  /// GPU reconstruction: the cameras whose images draw_cameras() unprojects (replacing earlier
  /// ones). Uploads each camera's ray table (RG32F, width x height of its depth intrinsics) and
  /// makes its depth and color textures at that size, empty until upload(). Throws Error if a
  /// camera has no pixels or OpenGL reports an error.
  void set_cameras(std::span<const CameraCalibration> cameras);
  /// Uploads camera `camera`'s images: depth in mm (0 = invalid) at the calibration's size, and
  /// color BGRA registered to it (same size) or empty (points drawn gray, as CloudBuilder does).
  /// Call when a camera's images change; draw_cameras() may draw them any number of times.
  /// Throws Error if `camera` is out of range or a size differs from the calibration.
  void upload(size_t camera, const CameraFrame& frame);
  /// As draw(), with the uploaded cameras' pixels as the points (see the top of this file); a
  /// camera not uploaded yet draws nothing, nor does a pixel with depth 0 or without a ray.
  void draw_cameras(const View& view, const RenderTarget& target);

  /// The avatar filter (avatar_filter.hpp) both draw() and draw_cameras() apply from now on, in
  /// their vertex shaders: a point it does not keep is not drawn. The default keeps every point.
  void set_avatar_filter(const AvatarFilter& filter);

  /// GL_RENDERER and GL_VERSION of the current context, e.g.
  /// "llvmpipe (LLVM 15.0.6, 256 bits), OpenGL 4.5 (Core Profile) Mesa 22.3.6".
  std::string gl_description() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  void begin_pass(const RenderTarget& target);
  void end_pass(const RenderTarget& target, size_t points);
};

}  // namespace volcast
