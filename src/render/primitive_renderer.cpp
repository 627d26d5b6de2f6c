#include "volcast/render/primitive_renderer.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "gl_util.hpp"
#include "lit_shaders.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

constexpr const char* kPass = "primitive renderer";

struct Mesh {
  GLuint vao = 0, vbo = 0;
  GLsizei vertices = 0;
};

// Interleaved position + normal triangles.
using Triangles = std::vector<float>;

void add_vertex(Triangles& t, const Eigen::Vector3f& p, const Eigen::Vector3f& n) {
  t.insert(t.end(), {p.x(), p.y(), p.z(), n.x(), n.y(), n.z()});
}

Triangles unit_box() {
  Triangles t;
  for (int axis = 0; axis < 3; ++axis)
    for (float sign : {-1.0f, 1.0f}) {
      Eigen::Vector3f n = Eigen::Vector3f::Zero();
      n[axis] = sign;
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      Eigen::Vector3f c[4];
      for (int k = 0; k < 4; ++k) {
        c[k] = 0.5f * n;
        c[k][u] = (k == 1 || k == 2) ? 0.5f : -0.5f;
        c[k][v] = (k >= 2) ? 0.5f : -0.5f;
      }
      // Counter-clockwise seen from outside.
      const bool flip = (c[1] - c[0]).cross(c[2] - c[0]).dot(n) < 0;
      const int order[6] = {0, 1, 2, 0, 2, 3};
      for (int k : order) {
        const int kk = flip ? (k == 1 ? 3 : k == 3 ? 1 : k) : k;
        add_vertex(t, c[kk], n);
      }
    }
  return t;
}

Triangles unit_sphere(int slices = 16, int stacks = 12) {
  Triangles t;
  const float pi = std::numbers::pi_v<float>;
  const auto at = [&](int i, int j) {
    const float theta = pi * float(j) / float(stacks), phi = 2 * pi * float(i) / float(slices);
    return Eigen::Vector3f(std::sin(theta) * std::cos(phi), std::cos(theta),
                           std::sin(theta) * std::sin(phi));
  };
  for (int j = 0; j < stacks; ++j)
    for (int i = 0; i < slices; ++i) {
      const Eigen::Vector3f a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      for (const Eigen::Vector3f& p : {a, b, c, a, c, d}) add_vertex(t, 0.5f * p, p);
    }
  return t;
}

Triangles unit_cylinder(int slices = 20) {
  Triangles t;
  const float pi = std::numbers::pi_v<float>;
  for (int i = 0; i < slices; ++i) {
    const float a0 = 2 * pi * float(i) / float(slices), a1 = 2 * pi * float(i + 1) / float(slices);
    const Eigen::Vector3f n0(std::cos(a0), 0, std::sin(a0)), n1(std::cos(a1), 0, std::sin(a1));
    const Eigen::Vector3f b0 = 0.5f * n0 - Eigen::Vector3f(0, 0.5f, 0),
                          b1 = 0.5f * n1 - Eigen::Vector3f(0, 0.5f, 0);
    const Eigen::Vector3f t0 = b0 + Eigen::Vector3f(0, 1, 0), t1 = b1 + Eigen::Vector3f(0, 1, 0);
    add_vertex(t, b0, n0);
    add_vertex(t, t1, n1);
    add_vertex(t, b1, n1);
    add_vertex(t, b0, n0);
    add_vertex(t, t0, n0);
    add_vertex(t, t1, n1);
    const Eigen::Vector3f up(0, 1, 0), top(0, 0.5f, 0), bottom(0, -0.5f, 0);
    add_vertex(t, top, up);
    add_vertex(t, t1, up);
    add_vertex(t, t0, up);
    add_vertex(t, bottom, -up);
    add_vertex(t, b0, -up);
    add_vertex(t, b1, -up);
  }
  return t;
}

Triangles unit_ring(int slices = 32) {
  Triangles t;
  const float pi = std::numbers::pi_v<float>;
  const Eigen::Vector3f up(0, 1, 0);
  for (int i = 0; i < slices; ++i) {
    const float a0 = 2 * pi * float(i) / float(slices), a1 = 2 * pi * float(i + 1) / float(slices);
    const Eigen::Vector3f d0(std::cos(a0), 0, std::sin(a0)), d1(std::cos(a1), 0, std::sin(a1));
    const Eigen::Vector3f i0 = 0.4f * d0, i1 = 0.4f * d1, o0 = 0.5f * d0, o1 = 0.5f * d1;
    for (const Eigen::Vector3f& p : {i0, i1, o1, i0, o1, o0}) add_vertex(t, p, up);
  }
  return t;
}

Mesh upload(const Triangles& t) {
  Mesh m;
  m.vertices = static_cast<GLsizei>(t.size() / 6);
  glCreateBuffers(1, &m.vbo);
  glNamedBufferStorage(m.vbo, static_cast<GLsizeiptr>(t.size() * sizeof(float)), t.data(), 0);
  m.vao = gl::lit_vertex_array(m.vbo);
  return m;
}

}  // namespace

Primitive box(const Eigen::Vector3f& center, const Eigen::Vector3f& size,
              const Eigen::Vector4f& rgba, float yaw_rad, float emissive) {
  Primitive p;
  p.shape = Primitive::Shape::kBox;
  Eigen::Affine3f a = Eigen::Translation3f(center) *
                      Eigen::AngleAxisf(yaw_rad, Eigen::Vector3f::UnitY()) * Eigen::Scaling(size);
  p.world_from_shape = a.matrix();
  p.color = rgba;
  p.emissive = emissive;
  return p;
}

struct PrimitiveRenderer::Impl {
  GLuint program = 0;
  Mesh meshes[4];
  gl::LitUniforms u;
  std::vector<size_t> order;
};

PrimitiveRenderer::PrimitiveRenderer() {
  gl::require_gl45(kPass);
  impl_ = std::make_unique<Impl>();
  Impl& r = *impl_;
  r.program = gl::link_program(kPass, gl::kLitVertex, nullptr, gl::kLitFragment);
  r.meshes[0] = upload(unit_box());
  r.meshes[1] = upload(unit_sphere());
  r.meshes[2] = upload(unit_cylinder());
  r.meshes[3] = upload(unit_ring());
  r.u = gl::LitUniforms(r.program);
  gl::check(kPass, "making the unit shapes");
}

PrimitiveRenderer::~PrimitiveRenderer() {
  for (Mesh& m : impl_->meshes) {
    glDeleteVertexArrays(1, &m.vao);
    glDeleteBuffers(1, &m.vbo);
  }
  glDeleteProgram(impl_->program);
}

void PrimitiveRenderer::draw(const View& view, const RenderTarget& target,
                             std::span<const Primitive> primitives, const Lighting& light) {
  Impl& r = *impl_;
  gl::bind_target(kPass, target);  // drawn over what is there: no clear
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_CULL_FACE);
  glUseProgram(r.program);
  r.u.set_view(view, light);
  const Eigen::Vector3f eye = view.world_from_view.translation.cast<float>();
  // Opaque first, then the transparent ones from far to near.
  r.order.clear();
  for (size_t i = 0; i < primitives.size(); ++i)
    if (primitives[i].color.w() >= 1) r.order.push_back(i);
  const size_t opaque = r.order.size();
  for (size_t i = 0; i < primitives.size(); ++i)
    if (primitives[i].color.w() < 1) r.order.push_back(i);
  const auto distance = [&](size_t i) {
    return (primitives[i].world_from_shape.topRightCorner<3, 1>() - eye).squaredNorm();
  };
  std::sort(r.order.begin() + static_cast<std::ptrdiff_t>(opaque), r.order.end(),
            [&](size_t a, size_t b) { return distance(a) > distance(b); });
  for (size_t k = 0; k < r.order.size(); ++k) {
    if (k == opaque) {
      glEnable(GL_BLEND);
      glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
      glDepthMask(GL_FALSE);
    }
    const Primitive& p = primitives[r.order[k]];
    const Mesh& m = r.meshes[static_cast<int>(p.shape) & 3];
    glUniformMatrix4fv(r.u.world_from_shape, 1, GL_FALSE, p.world_from_shape.data());
    glUniform4fv(r.u.color, 1, p.color.data());
    glUniform1f(r.u.emissive, std::clamp(p.emissive, 0.0f, 1.0f));
    glBindVertexArray(m.vao);
    glDrawArrays(GL_TRIANGLES, 0, m.vertices);
  }
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  glDisable(GL_SCISSOR_TEST);
  glBindVertexArray(0);
  gl::check(kPass, fmt::format("drawing {} primitives", primitives.size()).c_str());
}

}  // namespace volcast
