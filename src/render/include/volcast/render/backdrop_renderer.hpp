#pragma once
// A real camera's own picture as the backdrop of a 3D scene (the OR display): its colour image
// fills the target and its live depth goes into the depth buffer, so that what PrimitiveRenderer
// draws afterwards (it does not clear and depth-tests LESS) is hidden behind the real foreground
// -- a stroke behind the surgeon's hand is covered by the hand. OpenGL 4.5 core; like the other
// passes it creates no context and reads nothing back.
//
//   const View view = camera_view(calibration, 0.1f, 20);  // pinhole: undistorted images
//   backdrop.draw(view, target, frame);                      // colour + live depth
//   primitives.draw(view, target, avatars_pointers_strokes);  // occluded by the depth
//
// The view must be camera_view() of the camera that took `frame` (its pinhole intrinsics, at the
// frame's size); then target pixel (u, v) shows image pixel (u, v) when the target's viewport is
// the image's size, and pixel for pixel the same picture scaled when it is another size (nearest
// pixel). With any other view the backdrop still fills the viewport, but its depth does not
// match where the primitives land.
#include <memory>

#include "volcast/core/frame.hpp"
#include "volcast/render/render_target.hpp"
#include "volcast/render/view.hpp"

namespace volcast {

class BackdropRenderer {
 public:
  /// Builds the program in the OpenGL 4.5 context current on this thread. Throws Error if none is
  /// current, it is older than 4.5, or the shader fails.
  BackdropRenderer();
  /// Deletes the GL objects; the same context must still be current.
  ~BackdropRenderer();
  BackdropRenderer(const BackdropRenderer&) = delete;
  BackdropRenderer& operator=(const BackdropRenderer&) = delete;

  /// Uploads `frame` and draws it over the whole viewport of `target`, replacing what was there
  /// (colour and depth; nothing is blended):
  ///  - colour: frame.color (BGRA registered to the depth grid, the same size) as is, byte for
  ///    byte; a pixel with alpha 0 (no colour after registration) is black. Without a colour
  ///    image (empty): grey from depth, lighter nearer (0.9 at 0.5 m down to 0.2 at 4.5 m and
  ///    beyond), black where depth is invalid.
  ///  - depth: the depth the view's projection gives a point at the pixel's measured depth
  ///    (frame.depth, uint16 mm = Z along the optical axis, metres / 1000), clamped to the depth
  ///    range; invalid depth (0) is the far plane, so everything in front of it shows there.
  /// Leaves depth test LESS with writes on, blending and the scissor test off, like the other
  /// passes. Throws Error if the viewport is empty, the framebuffer incomplete, the depth image
  /// empty or larger than 8192 a side, the colour image neither empty nor the depth's size, the
  /// view's projection not a perspective whose depth depends on the view's z alone (as
  /// perspective_from_tangents makes), or OpenGL reports an error.
  void draw(const View& view, const RenderTarget& target, const CameraFrame& frame);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
