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
// Point clouds built on the CPU (CloudBuilder). Live cameras are drawn by CameraRenderer
// (camera_renderer.hpp), which reconstructs their points on the GPU.
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

  /// The avatar filter (avatar_filter.hpp) draw() applies from now on, in its vertex shader: a
  /// point it does not keep is not drawn. The default keeps every point.
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
