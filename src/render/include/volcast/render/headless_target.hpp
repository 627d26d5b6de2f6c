#pragma once
// Rendering without a window: an EGL context (Mesa's llvmpipe needs no GPU or display; on a GPU
// machine the vendor's EGL device is used) and an offscreen framebuffer to draw into, read back
// as an image only when a picture is wanted.
//
//   HeadlessTarget target(1280, 720);      // context current on this thread from here on
//   SplatRenderer splats;
//   splats.draw(clouds, to_view(camera, target.target().aspect()), target.target());
//   target.read_image(image);              // only when the picture is needed
#include <memory>
#include <vector>

#include "volcast/core/image.hpp"
#include "volcast/render/render_target.hpp"

namespace volcast {

/// A headless OpenGL 4.5 core context through EGL, with no surface (draw into FBOs). Made current
/// on the constructing thread. Destroy it on the thread where it is current, after every GL
/// object made in it.
class EglContext {
 public:
  /// Throws Error naming the EGL step that failed (no display, no OpenGL config, no 4.5 core
  /// context, cannot make it current).
  EglContext();
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

  /// Makes the context current on the calling thread (it must not be current on another one).
  /// Throws Error if EGL refuses.
  void make_current() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// An offscreen target: its own EglContext (current on the constructing thread) and a framebuffer
/// of width x height pixels with RGBA8 colour and 24-bit depth renderbuffers. Draw passes draw
/// into target(); read_image() reads the picture back, and nothing else does.
class HeadlessTarget {
 public:
  /// Throws Error if a side is outside 1..8192 pixels, the context cannot be created (see
  /// EglContext) or the framebuffer is incomplete.
  HeadlessTarget(int width, int height);
  /// Deletes the framebuffer, then the context; destroy passes that used it (SplatRenderer) first.
  ~HeadlessTarget();
  HeadlessTarget(const HeadlessTarget&) = delete;
  HeadlessTarget& operator=(const HeadlessTarget&) = delete;

  /// The whole framebuffer: {framebuffer, 0, 0, width, height}.
  RenderTarget target() const;
  int width() const;
  int height() const;
  const EglContext& context() const;

  /// Waits until every command issued in the context has finished (glFinish): for timing a pass,
  /// without reading anything back.
  void finish() const;

  /// Waits for drawing into the framebuffer to finish and copies its colour into `out` (resized
  /// to width x height; BGRA, alpha 255, top row first like every ColorImage). The only
  /// read-back. Throws Error if OpenGL reports an error.
  void read_image(ColorImage& out) const;

  /// Waits for drawing to finish and copies the depth buffer into `out` (resized to width x
  /// height, top row first like read_image): window-space depth 0 (near plane) .. 1 (far plane,
  /// and every pixel nothing was drawn into), as glDepthRange's default maps NDC z -1..1. Turn
  /// it into metres with the View's clip_from_view (view_depth_m in view.hpp). Throws Error if
  /// OpenGL reports an error.
  void read_depth(std::vector<float>& out) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
