#include "volcast/render/splat_renderer.hpp"

#include <epoxy/gl.h>
#include <fmt/format.h>

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "gl_util.hpp"
#include "volcast/core/error.hpp"
#include "volcast/render/glsl.hpp"

namespace volcast {
namespace {

constexpr const char* kVertexShader = R"(
layout(location = 0) in vec3 position;   // world, metres
layout(location = 1) in float radius;    // metres
layout(location = 2) in vec4 color;
uniform mat4 clip_from_world;
uniform float pixels_per_unit;           // viewport_height / 2 * P[1][1]
out vec4 v_color;
void main() {
  if (avatar_hidden(position)) {
    gl_Position = vec4(0.0, 0.0, 2.0, 1.0);       // beyond the far plane: clipped, nothing drawn
    gl_PointSize = 1.0;
    v_color = vec4(0.0);
    return;
  }
  gl_Position = clip_from_world * vec4(position, 1.0);
  gl_PointSize = clamp(2.0 * radius * pixels_per_unit / gl_Position.w, 1.0, 64.0);
  v_color = color;
}
)";

constexpr const char* kFragmentShader = R"(#version 450 core
in vec4 v_color;
out vec4 frag_color;
void main() {
  vec2 c = gl_PointCoord * 2.0 - 1.0;
  if (dot(c, c) > 1.0) discard;           // round splats
  frag_color = v_color;
}
)";

}  // namespace

struct SplatRenderer::Impl {
  GLuint program = 0, vao = 0, vbo = 0;
  GLint clip_from_world = -1, pixels_per_unit = -1;  // uniform locations
  size_t vbo_capacity = 0;                           // bytes
  gl::FilterUniforms filter_uniforms;
  AvatarFilter filter;
};

SplatRenderer::SplatRenderer() {
  gl::require_gl45("splat renderer");
  impl_ = std::make_unique<Impl>();
  Impl& r = *impl_;
  const std::string vertex = gl::glsl450(std::string(glsl::kAvatarFilterGlsl) + kVertexShader);
  r.program = gl::link_program("splat renderer", vertex.c_str(), nullptr, kFragmentShader);
  r.filter_uniforms = gl::FilterUniforms(r.program);
  r.clip_from_world = glGetUniformLocation(r.program, "clip_from_world");
  r.pixels_per_unit = glGetUniformLocation(r.program, "pixels_per_unit");

  glCreateVertexArrays(1, &r.vao);
  glCreateBuffers(1, &r.vbo);
  glVertexArrayVertexBuffer(r.vao, 0, r.vbo, 0, sizeof(SplatPoint));
  glEnableVertexArrayAttrib(r.vao, 0);
  glVertexArrayAttribFormat(r.vao, 0, 3, GL_FLOAT, GL_FALSE, offsetof(SplatPoint, position));
  glVertexArrayAttribBinding(r.vao, 0, 0);
  glEnableVertexArrayAttrib(r.vao, 1);
  glVertexArrayAttribFormat(r.vao, 1, 1, GL_FLOAT, GL_FALSE, offsetof(SplatPoint, radius));
  glVertexArrayAttribBinding(r.vao, 1, 0);
  glEnableVertexArrayAttrib(r.vao, 2);
  glVertexArrayAttribFormat(r.vao, 2, 4, GL_UNSIGNED_BYTE, GL_TRUE, offsetof(SplatPoint, rgba));
  glVertexArrayAttribBinding(r.vao, 2, 0);
}

SplatRenderer::~SplatRenderer() {
  Impl& r = *impl_;
  glDeleteBuffers(1, &r.vbo);
  glDeleteVertexArrays(1, &r.vao);
  glDeleteProgram(r.program);
}

void SplatRenderer::begin_pass(const RenderTarget& target) {
  gl::begin_target("splat renderer", target);
}

void SplatRenderer::end_pass(const RenderTarget& target, size_t points) {
  glDisable(GL_SCISSOR_TEST);
  if (const GLenum err = glGetError(); err != GL_NO_ERROR)
    throw Error(
        fmt::format("splat renderer: OpenGL error {:#x} drawing {} points into "
                    "framebuffer {}",
                    err, points, target.framebuffer));
}

void SplatRenderer::draw(std::span<const PointCloud* const> clouds, const View& view,
                         const RenderTarget& target) {
  Impl& r = *impl_;
  begin_pass(target);
  size_t total = 0;
  for (const PointCloud* c : clouds) total += c->points.size();
  const size_t bytes = total * sizeof(SplatPoint);
  if (bytes > r.vbo_capacity) {
    r.vbo_capacity = std::max(bytes, r.vbo_capacity * 3 / 2);
    glNamedBufferData(r.vbo, static_cast<GLsizeiptr>(r.vbo_capacity), nullptr, GL_STREAM_DRAW);
  }
  size_t offset = 0;
  for (const PointCloud* c : clouds) {
    const size_t n = c->points.size() * sizeof(SplatPoint);
    if (n)
      glNamedBufferSubData(r.vbo, static_cast<GLintptr>(offset), static_cast<GLsizeiptr>(n),
                           c->points.data());
    offset += n;
  }
  const Eigen::Matrix4f clip_from_world = view.clip_from_world();
  glUseProgram(r.program);
  glUniformMatrix4fv(r.clip_from_world, 1, GL_FALSE, clip_from_world.data());
  r.filter_uniforms.set(r.filter, Eigen::Matrix4f::Identity());
  glUniform1f(r.pixels_per_unit,
              0.5f * static_cast<float>(target.height) * view.clip_from_view(1, 1));
  glBindVertexArray(r.vao);
  glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(total));
  end_pass(target, total);
}

void SplatRenderer::set_avatar_filter(const AvatarFilter& filter) {
  impl_->filter = filter;
}

std::string SplatRenderer::gl_description() const {
  return std::string(reinterpret_cast<const char*>(glGetString(GL_RENDERER))) + ", OpenGL " +
         reinterpret_cast<const char*>(glGetString(GL_VERSION));
}

}  // namespace volcast
