#include "volcast/render/headless_target.hpp"

#include <epoxy/gl.h>
#include <fmt/format.h>

#include <algorithm>

#include "volcast/core/error.hpp"

namespace volcast {

struct HeadlessTarget::Impl {
  EglContext context;  // first: made before the GL objects below, destroyed after them
  int width = 0, height = 0;
  GLuint framebuffer = 0, color = 0, depth = 0;
};

HeadlessTarget::HeadlessTarget(int width, int height) {
  if (width <= 0 || height <= 0 || width > 8192 || height > 8192)
    throw Error(fmt::format("headless target: size {}x{} out of range, 1..8192 pixels a side",
                            width, height));
  impl_ = std::make_unique<Impl>();
  Impl& t = *impl_;
  t.width = width;
  t.height = height;
  glCreateRenderbuffers(1, &t.color);
  glNamedRenderbufferStorage(t.color, GL_RGBA8, width, height);
  glCreateRenderbuffers(1, &t.depth);
  glNamedRenderbufferStorage(t.depth, GL_DEPTH_COMPONENT24, width, height);
  glCreateFramebuffers(1, &t.framebuffer);
  glNamedFramebufferRenderbuffer(t.framebuffer, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, t.color);
  glNamedFramebufferRenderbuffer(t.framebuffer, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, t.depth);
  if (const GLenum status = glCheckNamedFramebufferStatus(t.framebuffer, GL_FRAMEBUFFER);
      status != GL_FRAMEBUFFER_COMPLETE) {
    glDeleteFramebuffers(1, &t.framebuffer);
    glDeleteRenderbuffers(1, &t.color);
    glDeleteRenderbuffers(1, &t.depth);
    throw Error(fmt::format("headless target: {}x{} framebuffer incomplete (status {:#x})", width,
                            height, status));
  }
}

HeadlessTarget::~HeadlessTarget() {
  Impl& t = *impl_;
  glDeleteFramebuffers(1, &t.framebuffer);
  glDeleteRenderbuffers(1, &t.color);
  glDeleteRenderbuffers(1, &t.depth);
}

RenderTarget HeadlessTarget::target() const {
  return {impl_->framebuffer, 0, 0, impl_->width, impl_->height};
}
int HeadlessTarget::width() const {
  return impl_->width;
}
int HeadlessTarget::height() const {
  return impl_->height;
}
const EglContext& HeadlessTarget::context() const {
  return impl_->context;
}

void HeadlessTarget::finish() const {
  glFinish();
}

void HeadlessTarget::read_image(ColorImage& out) const {
  const Impl& t = *impl_;
  if (out.width != t.width || out.height != t.height) out = ColorImage(t.width, t.height);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, t.framebuffer);
  glNamedFramebufferReadBuffer(t.framebuffer, GL_COLOR_ATTACHMENT0);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glPixelStorei(GL_PACK_ROW_LENGTH, 0);
  glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
  glReadnPixels(0, 0, t.width, t.height, GL_BGRA, GL_UNSIGNED_BYTE,
                static_cast<GLsizei>(out.bgra.size()), out.bgra.data());
  if (const GLenum err = glGetError(); err != GL_NO_ERROR)
    throw Error(
        fmt::format("headless target: reading the {}x{} image back failed (OpenGL error "
                    "{:#x})",
                    t.width, t.height, err));
  // OpenGL's first row is the bottom one; ColorImage's is the top one.
  const auto row = static_cast<std::ptrdiff_t>(t.width) * 4;
  for (int top = 0, bottom = t.height - 1; top < bottom; ++top, --bottom)
    std::swap_ranges(out.bgra.begin() + top * row, out.bgra.begin() + (top + 1) * row,
                     out.bgra.begin() + bottom * row);
}

void HeadlessTarget::read_depth(std::vector<float>& out) const {
  const Impl& t = *impl_;
  out.resize(static_cast<size_t>(t.width) * static_cast<size_t>(t.height));
  glBindFramebuffer(GL_READ_FRAMEBUFFER, t.framebuffer);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glPixelStorei(GL_PACK_ROW_LENGTH, 0);
  glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
  glReadnPixels(0, 0, t.width, t.height, GL_DEPTH_COMPONENT, GL_FLOAT,
                static_cast<GLsizei>(out.size() * sizeof(float)), out.data());
  if (const GLenum err = glGetError(); err != GL_NO_ERROR)
    throw Error(
        fmt::format("headless target: reading the {}x{} depth back failed (OpenGL error {:#x})",
                    t.width, t.height, err));
  const auto row = static_cast<std::ptrdiff_t>(t.width);
  for (int top = 0, bottom = t.height - 1; top < bottom; ++top, --bottom)
    std::swap_ranges(out.begin() + top * row, out.begin() + (top + 1) * row,
                     out.begin() + bottom * row);
}

}  // namespace volcast
