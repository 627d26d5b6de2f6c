#include "volcast/render/splat_renderer.hpp"

#include <epoxy/gl.h>
#include <fmt/format.h>

#include <algorithm>
#include <cstddef>
#include <vector>

#include "volcast/core/ray_table.hpp"

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

// The avatar filter (avatar_filter.hpp), in the frame of the pass's points: world for draw(), the
// camera's for draw_cameras(). The same inclusive tests as avatar_filter_keeps().
#define VOLCAST_AVATAR_FILTER                                                              \
  "uniform vec4 keep_sphere;         /* centre (metres), radius; radius <= 0: off */\n"    \
  "uniform mat4 headset_from_points;\n"                                                    \
  "uniform vec3 hide_half_extent;    /* metres; x <= 0: off */\n"                          \
  "bool avatar_hidden(vec3 p) {\n"                                                         \
  "  vec3 d = p - keep_sphere.xyz;\n"                                                      \
  "  if (keep_sphere.w > 0.0 && dot(d, d) > keep_sphere.w * keep_sphere.w) return true;\n" \
  "  if (hide_half_extent.x <= 0.0) return false;\n"                                       \
  "  vec3 h = abs((headset_from_points * vec4(p, 1.0)).xyz);\n"                            \
  "  return all(lessThanEqual(h, hide_half_extent));\n"                                    \
  "}\n"

constexpr const char* kVertexShader = "#version 450 core\n" VOLCAST_AVATAR_FILTER R"(
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

// GPU reconstruction: vertex gl_VertexID is depth pixel (id % width, id / width) of one camera.
constexpr const char* kCameraVertexShader = "#version 450 core\n" VOLCAST_AVATAR_FILTER R"(
layout(binding = 0) uniform usampler2D depth_mm;  // R16UI, 0 = invalid
layout(binding = 1) uniform sampler2D rays;       // RG32F: X/Z, Y/Z; NaN where the lens has none
layout(binding = 2) uniform sampler2D color;      // RGBA8, registered to depth
uniform bool has_color;
uniform int width;
uniform mat4 clip_from_camera;                    // clip_from_world * world_from_camera
uniform float radius_per_metre;
uniform float pixels_per_unit;
out vec4 v_color;
void main() {
  const ivec2 px = ivec2(gl_VertexID % width, gl_VertexID / width);
  const uint d = texelFetch(depth_mm, px, 0).r;
  const vec2 ray = texelFetch(rays, px, 0).rg;
  if (d == 0u || isnan(ray.x)) {
    gl_Position = vec4(0.0, 0.0, 2.0, 1.0);       // beyond the far plane: clipped, nothing drawn
    gl_PointSize = 1.0;
    v_color = vec4(0.0);
    return;
  }
  const float z = float(d) * 0.001;
  if (avatar_hidden(vec3(ray * z, z))) {
    gl_Position = vec4(0.0, 0.0, 2.0, 1.0);
    gl_PointSize = 1.0;
    v_color = vec4(0.0);
    return;
  }
  gl_Position = clip_from_camera * vec4(ray * z, z, 1.0);
  gl_PointSize = clamp(2.0 * z * radius_per_metre * pixels_per_unit / gl_Position.w, 1.0, 64.0);
  const vec4 c = texelFetch(color, px, 0);
  v_color = has_color && c.a > 0.0 ? vec4(c.rgb, 1.0) : vec4(vec3(160.0 / 255.0), 1.0);
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

GLuint compile(GLenum type, const char* source) {
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    throw Error(std::string("splat renderer: shader does not compile: ") + log);
  }
  return s;
}

GLuint link(const char* vertex_source, const char* fragment_source) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vertex_source);
  GLuint fs = 0;
  try {
    fs = compile(GL_FRAGMENT_SHADER, fragment_source);
  } catch (...) {
    glDeleteShader(vs);
    throw;
  }
  const GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetProgramInfoLog(program, sizeof log, nullptr, log);
    glDeleteProgram(program);
    throw Error(std::string("splat renderer: program does not link: ") + log);
  }
  return program;
}

GLuint texture(GLenum format, int width, int height) {
  GLuint t = 0;
  glCreateTextures(GL_TEXTURE_2D, 1, &t);
  glTextureStorage2D(t, 1, format, width, height);
  glTextureParameteri(t, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(t, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return t;
}

// One camera of the GPU reconstruction: its textures and where it sits.
struct GpuCamera {
  int width = 0, height = 0;
  GLuint rays = 0, depth = 0, color = 0;
  bool uploaded = false, has_color = false;
  Eigen::Matrix4f world_from_camera = Eigen::Matrix4f::Identity();
  float radius_per_metre = 0;
};

}  // namespace

struct SplatRenderer::Impl {
  GLuint program = 0, vao = 0, vbo = 0;
  GLint clip_from_world = -1, pixels_per_unit = -1;  // uniform locations
  size_t vbo_capacity = 0;                           // bytes
  // GPU reconstruction
  GLuint camera_program = 0, empty_vao = 0;
  GLint c_has_color = -1, c_width = -1, c_clip_from_camera = -1, c_radius_per_metre = -1,
        c_pixels_per_unit = -1;
  std::vector<GpuCamera> cameras;
  // The avatar filter: its uniforms in both programs, and the filter itself.
  struct FilterUniforms {
    GLint keep_sphere = -1, headset_from_points = -1, hide_half_extent = -1;
  } filter_points, filter_camera;
  AvatarFilter filter;

  // Sets `program`'s filter uniforms for points in a frame placed by `world_from_points`.
  void set_filter(const FilterUniforms& u, const Eigen::Matrix4f& world_from_points) const {
    Eigen::Vector4f sphere = Eigen::Vector4f::Zero();
    if (filter.keep) {
      const Eigen::Matrix4f points_from_world = world_from_points.inverse();
      sphere.head<3>() = (points_from_world * filter.keep->center.homogeneous()).head<3>();
      sphere.w() = filter.keep->radius_m;
    }
    glUniform4fv(u.keep_sphere, 1, sphere.data());
    Eigen::Matrix4f headset_from_points = Eigen::Matrix4f::Identity();
    Eigen::Vector3f half = Eigen::Vector3f::Zero();
    if (filter.hide) {
      headset_from_points =
          filter.hide->world_from_headset.inverse().matrix4f() * world_from_points;
      half = filter.hide->half_extent_m;
    }
    glUniformMatrix4fv(u.headset_from_points, 1, GL_FALSE, headset_from_points.data());
    glUniform3fv(u.hide_half_extent, 1, half.data());
  }

  void delete_cameras() {
    for (const GpuCamera& c : cameras) {
      const GLuint t[3] = {c.rays, c.depth, c.color};
      glDeleteTextures(3, t);
    }
    cameras.clear();
  }
};

SplatRenderer::SplatRenderer() {
  // glGetString answers null when no context is current (checked with libepoxy and Mesa).
  if (glGetString(GL_VERSION) == nullptr)
    throw Error("splat renderer: no OpenGL context is current on this thread");
  if (epoxy_gl_version() < 45 || !epoxy_is_desktop_gl())
    throw Error("splat renderer: OpenGL 4.5 is required, the current context has " +
                std::string(reinterpret_cast<const char*>(glGetString(GL_VERSION))));
  impl_ = std::make_unique<Impl>();
  Impl& r = *impl_;
  r.program = link(kVertexShader, kFragmentShader);
  try {
    r.camera_program = link(kCameraVertexShader, kFragmentShader);
  } catch (...) {
    glDeleteProgram(r.program);
    throw;
  }
  r.c_has_color = glGetUniformLocation(r.camera_program, "has_color");
  r.c_width = glGetUniformLocation(r.camera_program, "width");
  r.c_clip_from_camera = glGetUniformLocation(r.camera_program, "clip_from_camera");
  r.c_radius_per_metre = glGetUniformLocation(r.camera_program, "radius_per_metre");
  r.c_pixels_per_unit = glGetUniformLocation(r.camera_program, "pixels_per_unit");
  for (auto [program, u] :
       {std::pair{r.program, &r.filter_points}, std::pair{r.camera_program, &r.filter_camera}}) {
    u->keep_sphere = glGetUniformLocation(program, "keep_sphere");
    u->headset_from_points = glGetUniformLocation(program, "headset_from_points");
    u->hide_half_extent = glGetUniformLocation(program, "hide_half_extent");
  }
  glCreateVertexArrays(1, &r.empty_vao);  // the camera pass reads textures, not attributes
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
  r.delete_cameras();
  glDeleteBuffers(1, &r.vbo);
  glDeleteVertexArrays(1, &r.vao);
  glDeleteVertexArrays(1, &r.empty_vao);
  glDeleteProgram(r.program);
  glDeleteProgram(r.camera_program);
}

void SplatRenderer::begin_pass(const RenderTarget& target) {
  if (target.width <= 0 || target.height <= 0)
    throw Error(fmt::format("splat renderer: empty viewport {}x{} in framebuffer {}", target.width,
                            target.height, target.framebuffer));
  if (const GLenum status = glCheckNamedFramebufferStatus(target.framebuffer, GL_DRAW_FRAMEBUFFER);
      status != GL_FRAMEBUFFER_COMPLETE)
    throw Error(fmt::format("splat renderer: framebuffer {} is not complete (status {:#x})",
                            target.framebuffer, status));
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, target.framebuffer);
  glViewport(target.x, target.y, target.width, target.height);
  // The scissor keeps the clear, and splats that straddle the viewport's edge, inside it.
  glEnable(GL_SCISSOR_TEST);
  glScissor(target.x, target.y, target.width, target.height);
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
  r.set_filter(r.filter_points, Eigen::Matrix4f::Identity());
  glUniform1f(r.pixels_per_unit,
              0.5f * static_cast<float>(target.height) * view.clip_from_view(1, 1));
  glBindVertexArray(r.vao);
  glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(total));
  end_pass(target, total);
}

void SplatRenderer::set_cameras(std::span<const CameraCalibration> cameras) {
  Impl& r = *impl_;
  r.delete_cameras();
  for (const CameraCalibration& cal : cameras) {
    const Intrinsics& k = cal.depth;
    if (k.width <= 0 || k.height <= 0)
      throw Error(fmt::format("splat renderer: camera {} has no pixels ({}x{})", r.cameras.size(),
                              k.width, k.height));
    GpuCamera c;
    c.width = k.width;
    c.height = k.height;
    c.world_from_camera = cal.world_from_camera.matrix4f();
    c.radius_per_metre = splat_radius_per_metre(k);
    const RayTable rays = make_ray_table(k);
    std::vector<float> xy(rays.x.size() * 2);
    for (size_t i = 0; i < rays.x.size(); ++i) {
      xy[2 * i] = rays.x[i];
      xy[2 * i + 1] = rays.y[i];
    }
    c.rays = texture(GL_RG32F, c.width, c.height);
    c.depth = texture(GL_R16UI, c.width, c.height);
    c.color = texture(GL_RGBA8, c.width, c.height);
    r.cameras.push_back(c);  // owned from here: deleted with the others on error
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTextureSubImage2D(c.rays, 0, 0, 0, c.width, c.height, GL_RG, GL_FLOAT, xy.data());
  }
  if (const GLenum err = glGetError(); err != GL_NO_ERROR)
    throw Error(fmt::format("splat renderer: OpenGL error {:#x} making camera textures", err));
}

void SplatRenderer::upload(size_t camera, const CameraFrame& frame) {
  Impl& r = *impl_;
  if (camera >= r.cameras.size())
    throw Error(fmt::format("splat renderer: no camera {} (set_cameras gave {})", camera,
                            r.cameras.size()));
  GpuCamera& c = r.cameras[camera];
  if (frame.depth.width != c.width || frame.depth.height != c.height)
    throw Error(fmt::format("splat renderer: camera {} depth is {}x{}, its calibration {}x{}",
                            camera, frame.depth.width, frame.depth.height, c.width, c.height));
  c.has_color = !frame.color.empty();
  if (c.has_color && (frame.color.width != c.width || frame.color.height != c.height))
    throw Error(fmt::format("splat renderer: camera {} color is {}x{}, not registered to depth",
                            camera, frame.color.width, frame.color.height));
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(c.depth, 0, 0, 0, c.width, c.height, GL_RED_INTEGER, GL_UNSIGNED_SHORT,
                      frame.depth.pixels.data());
  if (c.has_color)
    glTextureSubImage2D(c.color, 0, 0, 0, c.width, c.height, GL_BGRA, GL_UNSIGNED_BYTE,
                        frame.color.bgra.data());
  c.uploaded = true;
}

void SplatRenderer::draw_cameras(const View& view, const RenderTarget& target) {
  Impl& r = *impl_;
  begin_pass(target);
  const Eigen::Matrix4f clip_from_world = view.clip_from_world();
  glUseProgram(r.camera_program);
  glUniform1f(r.c_pixels_per_unit,
              0.5f * static_cast<float>(target.height) * view.clip_from_view(1, 1));
  glBindVertexArray(r.empty_vao);
  size_t total = 0;
  for (const GpuCamera& c : r.cameras) {
    if (!c.uploaded) continue;
    const Eigen::Matrix4f clip_from_camera = clip_from_world * c.world_from_camera;
    glUniformMatrix4fv(r.c_clip_from_camera, 1, GL_FALSE, clip_from_camera.data());
    r.set_filter(r.filter_camera, c.world_from_camera);
    glUniform1i(r.c_width, c.width);
    glUniform1i(r.c_has_color, c.has_color ? 1 : 0);
    glUniform1f(r.c_radius_per_metre, c.radius_per_metre);
    glBindTextureUnit(0, c.depth);
    glBindTextureUnit(1, c.rays);
    glBindTextureUnit(2, c.color);
    const size_t n = static_cast<size_t>(c.width) * static_cast<size_t>(c.height);
    glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(n));
    total += n;
  }
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
