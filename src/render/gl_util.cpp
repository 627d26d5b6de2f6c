#include "gl_util.hpp"

#include <fmt/format.h>

#include <Eigen/LU>
#include <string>

#include "volcast/core/error.hpp"

namespace volcast::gl {
namespace {

GLuint compile(const char* pass, GLenum type, const char* source) {
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    throw Error(fmt::format("{}: shader does not compile: {}", pass, log));
  }
  return s;
}

GLuint link(const char* pass, const GLenum* types, const char* const* sources, int n) {
  GLuint shaders[3] = {0, 0, 0};
  try {
    for (int i = 0; i < n; ++i)
      if (sources[i]) shaders[i] = compile(pass, types[i], sources[i]);
  } catch (...) {
    for (GLuint s : shaders)
      if (s) glDeleteShader(s);
    throw;
  }
  const GLuint program = glCreateProgram();
  for (GLuint s : shaders)
    if (s) glAttachShader(program, s);
  glLinkProgram(program);
  for (GLuint s : shaders)
    if (s) glDeleteShader(s);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetProgramInfoLog(program, sizeof log, nullptr, log);
    glDeleteProgram(program);
    throw Error(fmt::format("{}: program does not link: {}", pass, log));
  }
  return program;
}

}  // namespace

GLuint link_program(const char* pass, const char* vertex, const char* geometry,
                    const char* fragment) {
  const GLenum types[3] = {GL_VERTEX_SHADER, GL_GEOMETRY_SHADER, GL_FRAGMENT_SHADER};
  const char* sources[3] = {vertex, geometry, fragment};
  return link(pass, types, sources, 3);
}

std::string glsl450(std::string_view body) {
  return "#version 450 core\n#define BINDING(n) layout(binding = n)\n" + std::string(body);
}

GLuint link_compute(const char* pass, const char* compute) {
  const GLenum type = GL_COMPUTE_SHADER;
  return link(pass, &type, &compute, 1);
}

GLuint make_texture(GLenum format, int width, int height) {
  GLuint t = 0;
  glCreateTextures(GL_TEXTURE_2D, 1, &t);
  glTextureStorage2D(t, 1, format, width, height);
  glTextureParameteri(t, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(t, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTextureParameteri(t, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(t, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return t;
}

void require_gl45(const char* pass) {
  // glGetString answers null when no context is current (checked with libepoxy and Mesa).
  if (glGetString(GL_VERSION) == nullptr)
    throw Error(std::string(pass) + ": no OpenGL context is current on this thread");
  if (epoxy_gl_version() < 45 || !epoxy_is_desktop_gl())
    throw Error(std::string(pass) + ": OpenGL 4.5 is required, the current context has " +
                reinterpret_cast<const char*>(glGetString(GL_VERSION)));
}

void bind_target(const char* pass, const RenderTarget& target) {
  if (target.width <= 0 || target.height <= 0)
    throw Error(fmt::format("{}: empty viewport {}x{} in framebuffer {}", pass, target.width,
                            target.height, target.framebuffer));
  if (const GLenum status = glCheckNamedFramebufferStatus(target.framebuffer, GL_DRAW_FRAMEBUFFER);
      status != GL_FRAMEBUFFER_COMPLETE)
    throw Error(fmt::format("{}: framebuffer {} is not complete (status {:#x})", pass,
                            target.framebuffer, status));
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, target.framebuffer);
  glViewport(target.x, target.y, target.width, target.height);
  // The scissor keeps the clear, and splats that straddle the viewport's edge, inside it.
  glEnable(GL_SCISSOR_TEST);
  glScissor(target.x, target.y, target.width, target.height);
}

void begin_target(const char* pass, const RenderTarget& target) {
  bind_target(pass, target);
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glDepthMask(GL_TRUE);
  glClearColor(0.08f, 0.09f, 0.11f, 1.0f);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_BLEND);
  glEnable(GL_PROGRAM_POINT_SIZE);
}

void check(const char* pass, const char* what) {
  if (const GLenum err = glGetError(); err != GL_NO_ERROR)
    throw Error(fmt::format("{}: OpenGL error {:#x} {}", pass, err, what));
}

FilterUniforms::FilterUniforms(GLuint program)
    : keep_sphere(program ? glGetUniformLocation(program, "keep_sphere") : -1),
      headset_from_points(program ? glGetUniformLocation(program, "headset_from_points") : -1),
      hide_half_extent(program ? glGetUniformLocation(program, "hide_half_extent") : -1) {}

void FilterUniforms::set(const AvatarFilter& filter,
                         const Eigen::Matrix4f& world_from_points) const {
  Eigen::Vector4f sphere = Eigen::Vector4f::Zero();
  if (filter.keep) {
    const Eigen::Matrix4f points_from_world = world_from_points.inverse();
    sphere.head<3>() = (points_from_world * filter.keep->center.homogeneous()).head<3>();
    sphere.w() = filter.keep->radius_m;
  }
  glUniform4fv(keep_sphere, 1, sphere.data());
  Eigen::Matrix4f headset_from_p = Eigen::Matrix4f::Identity();
  Eigen::Vector3f half = Eigen::Vector3f::Zero();
  if (filter.hide) {
    headset_from_p = filter.hide->world_from_headset.inverse().matrix4f() * world_from_points;
    half = filter.hide->half_extent_m;
  }
  glUniformMatrix4fv(headset_from_points, 1, GL_FALSE, headset_from_p.data());
  glUniform3fv(hide_half_extent, 1, half.data());
}

}  // namespace volcast::gl
