#include "screenshot.hpp"

#include <epoxy/gl.h>
#include <fmt/format.h>

#include <cstring>
#include <string>

#include "volcast/core/error.hpp"
#include "volcast/core/image.hpp"
#include "volcast/core/image_io.hpp"

namespace volcast {

std::filesystem::path screenshot_path(const std::filesystem::path& configured) {
  if (!configured.empty()) return configured;
  for (int n = 1;; ++n) {
    std::filesystem::path path = fmt::format("volcast-screenshot-{}.png", n);
    if (!std::filesystem::exists(path)) return path;
  }
}

void save_screenshot(int width, int height, const std::filesystem::path& path) {
  std::vector<uint8_t> rgba(static_cast<size_t>(width) * height * 4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  glReadBuffer(GL_BACK);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadnPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, static_cast<GLsizei>(rgba.size()),
                rgba.data());
  if (const GLenum error = glGetError(); error != GL_NO_ERROR)
    throw Error(fmt::format("screenshot: glReadPixels failed (GL error 0x{:x})", error));
  ColorImage image(width, height);  // BGRA, top row first
  for (int y = 0; y < height; ++y) {
    const uint8_t* from = &rgba[static_cast<size_t>(height - 1 - y) * width * 4];
    for (int x = 0; x < width; ++x, from += 4) {
      uint8_t* to = image.pixel(x, y);
      to[0] = from[2], to[1] = from[1], to[2] = from[0], to[3] = 255;
    }
  }
  write_color_png(path, image);
}

}  // namespace volcast
