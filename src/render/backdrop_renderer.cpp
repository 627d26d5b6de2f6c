#include "volcast/render/backdrop_renderer.hpp"

#include <epoxy/gl.h>
#include <fmt/format.h>

#include "gl_util.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

constexpr const char* kBackdropPass = "backdrop renderer";

// One triangle over the viewport.
constexpr const char* kBackdropVertex = R"(#version 450 core
void main() {
  const vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
)";

// Each fragment takes the image pixel under its centre (the image's top row at the viewport's
// top), its colour, and the window depth of the view point (x, y, -Z) at the measured Z:
// ndc_z = (a z + b) / (c z + d) with (a, b) and (c, d) the z and w columns of clip_from_view's
// rows 2 and 3.
constexpr const char* kBackdropFragment = R"(#version 450 core
layout(binding = 0) uniform usampler2D depth_mm;  // R16UI, 0 = invalid
layout(binding = 1) uniform sampler2D color_tex;  // RGBA8, registered to depth
uniform bool has_color;
uniform ivec4 viewport;  // x, y, width, height in the framebuffer
uniform vec4 depth_of_z;  // a, b, c, d (see above)
out vec4 frag_color;
void main() {
  const ivec2 size = textureSize(depth_mm, 0);
  const vec2 f = (gl_FragCoord.xy - vec2(viewport.xy)) / vec2(viewport.zw);
  const ivec2 px = clamp(ivec2(floor(vec2(f.x, 1.0 - f.y) * vec2(size))), ivec2(0), size - 1);
  const uint d = texelFetch(depth_mm, px, 0).r;
  const float z = float(d) * 0.001;
  if (has_color) {
    const vec4 c = texelFetch(color_tex, px, 0);
    frag_color = vec4(c.a > 0.0 ? c.rgb : vec3(0.0), 1.0);
  } else {
    const float grey = d == 0u ? 0.0 : mix(0.9, 0.2, clamp((z - 0.5) / 4.0, 0.0, 1.0));
    frag_color = vec4(vec3(grey), 1.0);
  }
  float ndc = 1.0;
  if (d != 0u) ndc = clamp((depth_of_z.x * -z + depth_of_z.y) / (depth_of_z.z * -z + depth_of_z.w),
                           -1.0, 1.0);
  gl_FragDepth = 0.5 * gl_DepthRange.diff * ndc + 0.5 * (gl_DepthRange.near + gl_DepthRange.far);
}
)";

}  // namespace

struct BackdropRenderer::Impl {
  GLuint program = 0, empty_vao = 0, depth = 0, color = 0;
  GLint has_color = -1, viewport = -1, depth_of_z = -1;
  int width = 0, height = 0;

  // (Re)makes the textures for a width x height frame.
  void ensure_textures(int w, int h) {
    if (depth && width == w && height == h) return;
    const GLuint old[2] = {depth, color};
    glDeleteTextures(2, old);
    depth = gl::make_texture(GL_R16UI, w, h);
    color = gl::make_texture(GL_RGBA8, w, h);
    width = w;
    height = h;
  }
};

BackdropRenderer::BackdropRenderer() {
  gl::require_gl45(kBackdropPass);
  impl_ = std::make_unique<Impl>();
  Impl& r = *impl_;
  r.program = gl::link_program(kBackdropPass, kBackdropVertex, nullptr, kBackdropFragment);
  r.has_color = glGetUniformLocation(r.program, "has_color");
  r.viewport = glGetUniformLocation(r.program, "viewport");
  r.depth_of_z = glGetUniformLocation(r.program, "depth_of_z");
  glCreateVertexArrays(1, &r.empty_vao);
  gl::check(kBackdropPass, "building the program");
}

BackdropRenderer::~BackdropRenderer() {
  Impl& r = *impl_;
  const GLuint t[2] = {r.depth, r.color};
  glDeleteTextures(2, t);
  glDeleteVertexArrays(1, &r.empty_vao);
  glDeleteProgram(r.program);
}

void BackdropRenderer::draw(const View& view, const RenderTarget& target,
                            const CameraFrame& frame) {
  Impl& r = *impl_;
  const DepthImage& depth = frame.depth;
  if (depth.width <= 0 || depth.height <= 0 || depth.width > 8192 || depth.height > 8192 ||
      depth.pixels.size() != static_cast<size_t>(depth.width) * depth.height)
    throw Error(fmt::format("{}: depth image {}x{} is empty or larger than 8192 a side",
                            kBackdropPass, depth.width, depth.height));
  const bool has_color = !frame.color.empty();
  if (has_color && (frame.color.width != depth.width || frame.color.height != depth.height))
    throw Error(fmt::format("{}: colour image {}x{} is not registered to the {}x{} depth",
                            kBackdropPass, frame.color.width, frame.color.height, depth.width,
                            depth.height));
  const Eigen::Matrix4f& p = view.clip_from_view;
  if (p(2, 0) != 0 || p(2, 1) != 0 || p(3, 0) != 0 || p(3, 1) != 0)
    throw Error(
        fmt::format("{}: the view's projection makes depth depend on x or y; use "
                    "camera_view() of the camera that took the frame",
                    kBackdropPass));
  gl::bind_target(kBackdropPass, target);
  r.ensure_textures(depth.width, depth.height);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
  glTextureSubImage2D(r.depth, 0, 0, 0, depth.width, depth.height, GL_RED_INTEGER,
                      GL_UNSIGNED_SHORT, depth.pixels.data());
  if (has_color)
    glTextureSubImage2D(r.color, 0, 0, 0, depth.width, depth.height, GL_BGRA, GL_UNSIGNED_BYTE,
                        frame.color.bgra.data());

  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_ALWAYS);  // replace whatever depth was there
  glDepthMask(GL_TRUE);
  glUseProgram(r.program);
  glUniform1i(r.has_color, has_color ? 1 : 0);
  glUniform4i(r.viewport, target.x, target.y, target.width, target.height);
  glUniform4f(r.depth_of_z, p(2, 2), p(2, 3), p(3, 2), p(3, 3));
  glBindTextureUnit(0, r.depth);
  glBindTextureUnit(1, r.color);
  glBindVertexArray(r.empty_vao);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glDepthFunc(GL_LESS);
  glDisable(GL_SCISSOR_TEST);
  gl::check(kBackdropPass, fmt::format("drawing a {}x{} frame into framebuffer {}", depth.width,
                                       depth.height, target.framebuffer)
                               .c_str());
}

}  // namespace volcast
