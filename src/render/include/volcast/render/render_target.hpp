#pragma once
// Where a draw pass draws: a rectangle of an OpenGL framebuffer that somebody else owns (a
// window's default framebuffer, an OpenXR swapchain image attached to an FBO, a HeadlessTarget).
#include <cstdint>

namespace volcast {

/// A viewport in a framebuffer. Passes draw only inside it (they clear and draw with the scissor
/// test set to it) and never create, resize or delete the framebuffer. The framebuffer must be
/// complete, in the context current on the drawing thread, with a depth attachment for passes
/// that depth-test (all of ours do).
struct RenderTarget {
  uint32_t framebuffer = 0;  ///< GL framebuffer object name; 0 = the default framebuffer (window)
  int x = 0, y = 0;  ///< viewport's lower-left corner, pixels from the framebuffer's lower left
  int width = 0, height = 0;  ///< viewport size, pixels, > 0

  /// width / height, the aspect ratio a projection for this viewport needs.
  float aspect() const { return static_cast<float>(width) / static_cast<float>(height); }
};

}  // namespace volcast
