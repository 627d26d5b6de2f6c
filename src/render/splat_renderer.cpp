#include "volcast/render/splat_renderer.hpp"

#include <epoxy/gl.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "egl_context.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

constexpr const char* kVertexShader = R"(#version 450 core
layout(location = 0) in vec3 position;   // world, metres
layout(location = 1) in float radius;    // metres
layout(location = 2) in vec4 color;
uniform mat4 clip_from_world;
uniform float pixels_per_unit;           // viewport_height / 2 * P[1][1]
out vec4 v_color;
void main() {
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
    throw Error(std::string("splat shader does not compile: ") + log);
  }
  return s;
}

Eigen::Matrix4f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target,
                        const Eigen::Vector3f& up) {
  const Eigen::Vector3f f = (target - eye).normalized();
  const Eigen::Vector3f s = f.cross(up).normalized();
  const Eigen::Vector3f u = s.cross(f);
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.row(0).head<3>() = s;
  m.row(1).head<3>() = u;
  m.row(2).head<3>() = -f;
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

Eigen::Matrix4f perspective(float fovy_deg, float aspect, float near, float far) {
  const float t = 1.0f / std::tan(fovy_deg * std::numbers::pi_v<float> / 360.0f);
  Eigen::Matrix4f p = Eigen::Matrix4f::Zero();
  p(0, 0) = t / aspect;
  p(1, 1) = t;
  p(2, 2) = (far + near) / (near - far);
  p(2, 3) = 2 * far * near / (near - far);
  p(3, 2) = -1;
  return p;
}

}  // namespace

struct SplatRenderer::Impl {
  detail::EglContext egl;
  int width, height;
  GLuint fbo = 0, color_rb = 0, depth_rb = 0, program = 0, vao = 0, vbo = 0;
  size_t vbo_capacity = 0;
  std::vector<uint8_t> readback;
};

SplatRenderer::SplatRenderer(int width, int height) : impl_(std::make_unique<Impl>()) {
  if (width <= 0 || height <= 0 || width > 8192 || height > 8192)
    throw Error("renderer: image size must be 1..8192 pixels a side");
  Impl& r = *impl_;
  r.width = width;
  r.height = height;
  if (epoxy_gl_version() < 45)
    throw Error("renderer: OpenGL 4.5 is required, got " + std::to_string(epoxy_gl_version() / 10) +
                "." + std::to_string(epoxy_gl_version() % 10));
  glCreateRenderbuffers(1, &r.color_rb);
  glNamedRenderbufferStorage(r.color_rb, GL_RGBA8, width, height);
  glCreateRenderbuffers(1, &r.depth_rb);
  glNamedRenderbufferStorage(r.depth_rb, GL_DEPTH_COMPONENT24, width, height);
  glCreateFramebuffers(1, &r.fbo);
  glNamedFramebufferRenderbuffer(r.fbo, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, r.color_rb);
  glNamedFramebufferRenderbuffer(r.fbo, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, r.depth_rb);
  if (glCheckNamedFramebufferStatus(r.fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw Error("renderer: offscreen framebuffer incomplete");

  const GLuint vs = compile(GL_VERTEX_SHADER, kVertexShader);
  const GLuint fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
  r.program = glCreateProgram();
  glAttachShader(r.program, vs);
  glAttachShader(r.program, fs);
  glLinkProgram(r.program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(r.program, GL_LINK_STATUS, &ok);
  if (!ok) throw Error("renderer: splat program does not link");

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
  glDeleteFramebuffers(1, &r.fbo);
  glDeleteRenderbuffers(1, &r.color_rb);
  glDeleteRenderbuffers(1, &r.depth_rb);
}

void SplatRenderer::render(std::span<const PointCloud* const> clouds, const ViewCamera& view,
                           ColorImage& out) {
  Impl& r = *impl_;
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

  const Eigen::Matrix4f proj =
      perspective(view.vertical_fov_deg, float(r.width) / float(r.height), view.near_m, view.far_m);
  const Eigen::Matrix4f clip_from_world = proj * look_at(view.eye, view.target, view.up);
  glBindFramebuffer(GL_FRAMEBUFFER, r.fbo);
  glViewport(0, 0, r.width, r.height);
  glClearColor(0.08f, 0.09f, 0.11f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_PROGRAM_POINT_SIZE);
  glUseProgram(r.program);
  glUniformMatrix4fv(glGetUniformLocation(r.program, "clip_from_world"), 1, GL_FALSE,
                     clip_from_world.data());
  glUniform1f(glGetUniformLocation(r.program, "pixels_per_unit"),
              0.5f * float(r.height) * proj(1, 1));
  glBindVertexArray(r.vao);
  glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(total));

  r.readback.resize(static_cast<size_t>(r.width) * r.height * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, r.width, r.height, GL_BGRA, GL_UNSIGNED_BYTE, r.readback.data());
  if (out.width != r.width || out.height != r.height) out = ColorImage(r.width, r.height);
  const size_t row = static_cast<size_t>(r.width) * 4;
  for (int y = 0; y < r.height; ++y)  // GL's first row is the bottom one
    std::copy_n(&r.readback[row * (r.height - 1 - y)], row, &out.bgra[row * y]);
  if (GLenum err = glGetError(); err != GL_NO_ERROR)
    throw Error("renderer: OpenGL error " + std::to_string(err));
}

std::string SplatRenderer::gl_description() const {
  return std::string(reinterpret_cast<const char*>(glGetString(GL_RENDERER))) + ", OpenGL " +
         reinterpret_cast<const char*>(glGetString(GL_VERSION));
}

ViewCamera orbit_view(const RigidTransform& world_from_camera,
                      std::span<const PointCloud* const> clouds, float yaw_deg, float pitch_deg) {
  const Eigen::Vector3d eye = world_from_camera.translation;
  const Eigen::Vector3d forward = world_from_camera.rotation * Eigen::Vector3d(0, 0, 1);
  const Eigen::Vector3d up = world_from_camera.rotation * Eigen::Vector3d(0, -1, 0);
  const Eigen::Vector3d right = world_from_camera.rotation * Eigen::Vector3d(1, 0, 0);
  // Pivot at the median distance along the camera's axis (robust to a far floor or wall).
  std::vector<float> along;
  for (const PointCloud* c : clouds)
    for (size_t i = 0; i < c->points.size(); i += 16) {
      const float* p = c->points[i].position;
      along.push_back(static_cast<float>((Eigen::Vector3d(p[0], p[1], p[2]) - eye).dot(forward)));
    }
  double distance = 1.0;
  if (!along.empty()) {
    std::nth_element(along.begin(), along.begin() + static_cast<std::ptrdiff_t>(along.size() / 2),
                     along.end());
    distance = std::max(0.3, static_cast<double>(along[along.size() / 2]));
  }
  const Eigen::Vector3d pivot = eye + forward * distance;
  const double to_rad = std::numbers::pi / 180;
  const Eigen::Matrix3d turn =
      (Eigen::AngleAxisd(yaw_deg * to_rad, up) * Eigen::AngleAxisd(-pitch_deg * to_rad, right))
          .toRotationMatrix();
  ViewCamera v;
  v.target = pivot.cast<float>();
  v.eye = (pivot + turn * (eye - pivot)).cast<float>();
  v.up = up.cast<float>();
  return v;
}

}  // namespace volcast
