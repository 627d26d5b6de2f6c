#include "volcast/render/case_renderer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <vector>

#include "gl_util.hpp"
#include "lit_shaders.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

constexpr const char* kPass = "case renderer";

constexpr const char* kQuadVertex = R"(#version 450 core
uniform mat4 clip_from_quad;
out vec2 uv;
void main() {
  vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));
  uv = vec2(corner.x, 1.0 - corner.y);  // image row 0 at the top
  gl_Position = clip_from_quad * vec4(corner - 0.5, 0.0, 1.0);
}
)";

constexpr const char* kQuadFragment = R"(#version 450 core
in vec2 uv;
uniform sampler2D image;
out vec4 out_color;
void main() { out_color = vec4(texture(image, uv).rgb, 1.0); }
)";

struct PartMesh {
  GLuint vao = 0, vbo = 0, ebo = 0;
  GLsizei indices = 0;
  Eigen::Vector4f rgba;
  Eigen::Vector3f center;  // object frame
};

Eigen::Matrix4f matrix(const Pose& p) {
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.topLeftCorner<3, 3>() = p.orientation.normalized().toRotationMatrix();
  m.topRightCorner<3, 1>() = p.position;
  return m;
}

}  // namespace

struct CaseRenderer::Impl {
  GLuint program = 0, quad_program = 0, quad_vao = 0, texture = 0;
  gl::LitUniforms u;
  GLint clip_from_quad = -1;
  const SharedCase* uploaded = nullptr;
  uint32_t uploaded_generation = 0;
  std::vector<std::vector<PartMesh>> objects;
  // The monitor's texture and what it shows.
  const MonitorSeries* series = nullptr;
  MonitorState shown;
  int texture_width = 0, texture_height = 0;

  void release_meshes() {
    for (auto& parts : objects)
      for (PartMesh& m : parts) {
        glDeleteVertexArrays(1, &m.vao);
        glDeleteBuffers(1, &m.vbo);
        glDeleteBuffers(1, &m.ebo);
      }
    objects.clear();
  }

  void upload(const SharedCase& c) {
    release_meshes();
    for (const SharedObject& o : c.objects) {
      std::vector<PartMesh> parts;
      for (const SharedPart& p : o.parts) {
        if (p.indices.empty()) continue;
        PartMesh m;
        m.rgba = p.rgba;
        m.indices = static_cast<GLsizei>(p.indices.size());
        Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
        std::vector<float> interleaved;
        interleaved.reserve(p.positions.size() * 6);
        for (size_t i = 0; i < p.positions.size(); ++i) {
          const Eigen::Vector3f& v = p.positions[i];
          const Eigen::Vector3f n = i < p.normals.size() ? p.normals[i] : Eigen::Vector3f::UnitY();
          interleaved.insert(interleaved.end(), {v.x(), v.y(), v.z(), n.x(), n.y(), n.z()});
          lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
        }
        m.center = (lo + hi) / 2;
        glCreateBuffers(1, &m.vbo);
        glNamedBufferStorage(m.vbo, static_cast<GLsizeiptr>(interleaved.size() * sizeof(float)),
                             interleaved.data(), 0);
        glCreateBuffers(1, &m.ebo);
        glNamedBufferStorage(m.ebo, static_cast<GLsizeiptr>(p.indices.size() * sizeof(uint32_t)),
                             p.indices.data(), 0);
        m.vao = gl::lit_vertex_array(m.vbo, m.ebo);
        parts.push_back(m);
      }
      objects.push_back(std::move(parts));
    }
    uploaded = &c;
    uploaded_generation = c.generation;
    gl::check(kPass, "uploading the case's meshes");
  }
};

CaseRenderer::CaseRenderer() {
  gl::require_gl45(kPass);
  impl_ = std::make_unique<Impl>();
  Impl& r = *impl_;
  r.program = gl::link_program(kPass, gl::kLitVertex, nullptr, gl::kLitFragment);
  r.u = gl::LitUniforms(r.program);
  r.quad_program = gl::link_program(kPass, kQuadVertex, nullptr, kQuadFragment);
  r.clip_from_quad = glGetUniformLocation(r.quad_program, "clip_from_quad");
  glCreateVertexArrays(1, &r.quad_vao);
  gl::check(kPass, "building its programs");
}

CaseRenderer::~CaseRenderer() {
  Impl& r = *impl_;
  r.release_meshes();
  glDeleteTextures(1, &r.texture);
  glDeleteVertexArrays(1, &r.quad_vao);
  glDeleteProgram(r.quad_program);
  glDeleteProgram(r.program);
}

void CaseRenderer::clear(const RenderTarget& target) {
  gl::begin_target(kPass, target);
  glDisable(GL_SCISSOR_TEST);
}

void CaseRenderer::draw(const View& view, const RenderTarget& target, const SharedCase& c,
                        std::span<const PlacedObject> placed, const Lighting& light) {
  Impl& r = *impl_;
  if (r.uploaded != &c || r.uploaded_generation != c.generation) r.upload(c);
  gl::bind_target(kPass, target);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glUseProgram(r.program);
  r.u.set_view(view, light);
  const Eigen::Vector3f eye = view.world_from_view.translation.cast<float>();
  struct Item {
    const PartMesh* mesh;
    Eigen::Matrix4f world_from_object;
    float highlight, distance;
  };
  std::vector<Item> opaque, blended;
  const size_t n = std::min(placed.size(), r.objects.size());
  for (size_t o = 0; o < n; ++o) {
    const Eigen::Matrix4f m = matrix(placed[o].pose);
    for (const PartMesh& part : r.objects[o]) {
      const Eigen::Vector3f center = (m * part.center.homogeneous()).head<3>();
      Item item{&part, m, placed[o].highlight, (center - eye).squaredNorm()};
      (part.rgba.w() >= 1 ? opaque : blended).push_back(item);
    }
  }
  std::sort(blended.begin(), blended.end(),
            [](const Item& a, const Item& b) { return a.distance > b.distance; });
  const auto draw_item = [&](const Item& item) {
    glUniformMatrix4fv(r.u.world_from_shape, 1, GL_FALSE, item.world_from_object.data());
    glUniform4fv(r.u.color, 1, item.mesh->rgba.data());
    glUniform1f(r.u.emissive, std::clamp(item.highlight, 0.0f, 1.0f));
    glBindVertexArray(item.mesh->vao);
    glDrawElements(GL_TRIANGLES, item.mesh->indices, GL_UNSIGNED_INT, nullptr);
  };
  for (const Item& item : opaque) draw_item(item);
  if (!blended.empty()) {
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glDepthMask(GL_FALSE);
    glEnable(GL_CULL_FACE);
    for (const Item& item : blended)
      for (GLenum cull : {GL_FRONT, GL_BACK}) {
        glCullFace(cull);
        draw_item(item);
      }
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
  }
  glBindVertexArray(0);
  glDisable(GL_SCISSOR_TEST);
  gl::check(kPass, fmt::format("drawing {} parts", opaque.size() + blended.size()).c_str());
}

void CaseRenderer::draw_monitor(const View& view, const RenderTarget& target,
                                const MonitorSeries& series, const MonitorState& state,
                                const Eigen::Matrix4f& world_from_quad) {
  Impl& r = *impl_;
  const bool same = r.series == &series && r.shown.generation == state.generation &&
                    r.shown.slice == state.slice && r.shown.center == state.center &&
                    r.shown.width == state.width && r.shown.overlay == state.overlay;
  if (!same) {
    const std::vector<uint8_t> rgba = monitor_image(series, state);
    if (r.texture_width != series.width || r.texture_height != series.height) {
      glDeleteTextures(1, &r.texture);
      glCreateTextures(GL_TEXTURE_2D, 1, &r.texture);
      glTextureStorage2D(r.texture, 1, GL_RGBA8, series.width, series.height);
      glTextureParameteri(r.texture, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTextureParameteri(r.texture, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTextureParameteri(r.texture, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
      glTextureParameteri(r.texture, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
      r.texture_width = series.width, r.texture_height = series.height;
    }
    glTextureSubImage2D(r.texture, 0, 0, 0, series.width, series.height, GL_RGBA, GL_UNSIGNED_BYTE,
                        rgba.data());
    r.series = &series;
    r.shown = state;
  }
  gl::bind_target(kPass, target);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  glUseProgram(r.quad_program);
  const Eigen::Matrix4f clip = view.clip_from_world() * world_from_quad;
  glUniformMatrix4fv(r.clip_from_quad, 1, GL_FALSE, clip.data());
  glBindTextureUnit(0, r.texture);
  glBindVertexArray(r.quad_vao);
  glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
  glBindVertexArray(0);
  glDepthFunc(GL_LESS);
  glDisable(GL_SCISSOR_TEST);
  gl::check(kPass, "drawing the monitor");
}

}  // namespace volcast
