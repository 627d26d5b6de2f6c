#pragma once
// The lit-surface shaders the primitive and case passes share (internal to src/render): a
// vertex stream of position + normal (locations 0, 1) placed by world_from_shape, Lambert from
// a key light and the OR lamp, ambient, a faint rim, `emissive` toward the unlit colour.
#include <epoxy/gl.h>

#include "volcast/render/primitive_renderer.hpp"
#include "volcast/render/view.hpp"

namespace volcast::gl {

inline constexpr const char* kLitVertex = R"(#version 450 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
uniform mat4 clip_from_world;
uniform mat4 world_from_shape;
out vec3 world_position;
out vec3 world_normal;
void main() {
  vec4 p = world_from_shape * vec4(position, 1.0);
  world_position = p.xyz;
  world_normal = transpose(inverse(mat3(world_from_shape))) * normal;
  gl_Position = clip_from_world * p;
}
)";

inline constexpr const char* kLitFragment = R"(#version 450 core
in vec3 world_position;
in vec3 world_normal;
uniform vec4 color;
uniform float emissive;
uniform vec3 to_key_light, key_color, ambient;
uniform vec4 point_light;  // position, range (<= 0: off)
uniform vec3 point_color;
uniform vec3 eye;
out vec4 out_color;
void main() {
  vec3 n = normalize(world_normal);
  if (!gl_FrontFacing) n = -n;  // rings and the insides of walls
  vec3 light = ambient + key_color * max(dot(n, to_key_light), 0.0);
  if (point_light.w > 0.0) {
    vec3 d = point_light.xyz - world_position;
    float r = length(d);
    float falloff = clamp(1.0 - r / point_light.w, 0.0, 1.0);
    light += point_color * max(dot(n, d / max(r, 1e-4)), 0.0) * falloff * falloff;
  }
  // A faint rim toward the eye keeps shapes readable against the dark background.
  float rim = pow(1.0 - max(dot(n, normalize(eye - world_position)), 0.0), 3.0) * 0.15;
  vec3 lit = color.rgb * light + rim;
  out_color = vec4(mix(lit, color.rgb, emissive), color.a);
}
)";

/// A vertex array of interleaved position + normal floats (locations 0, 1) from `vbo`, with
/// `ebo` as its element buffer when not 0.
inline GLuint lit_vertex_array(GLuint vbo, GLuint ebo = 0) {
  GLuint vao = 0;
  glCreateVertexArrays(1, &vao);
  glVertexArrayVertexBuffer(vao, 0, vbo, 0, 6 * sizeof(float));
  if (ebo) glVertexArrayElementBuffer(vao, ebo);
  for (GLuint attribute : {0u, 1u}) {
    glEnableVertexArrayAttrib(vao, attribute);
    glVertexArrayAttribFormat(vao, attribute, 3, GL_FLOAT, GL_FALSE, attribute * 3 * sizeof(float));
    glVertexArrayAttribBinding(vao, attribute, 0);
  }
  return vao;
}

/// The lit program's uniform locations, and setting the per-draw-call ones.
struct LitUniforms {
  GLint clip_from_world = -1, world_from_shape = -1, color = -1, emissive = -1, to_key_light = -1,
        key_color = -1, ambient = -1, point_light = -1, point_color = -1, eye = -1;
  explicit LitUniforms(GLuint program = 0) {
    if (!program) return;
    const auto loc = [&](const char* name) { return glGetUniformLocation(program, name); };
    clip_from_world = loc("clip_from_world");
    world_from_shape = loc("world_from_shape");
    color = loc("color");
    emissive = loc("emissive");
    to_key_light = loc("to_key_light");
    key_color = loc("key_color");
    ambient = loc("ambient");
    point_light = loc("point_light");
    point_color = loc("point_color");
    eye = loc("eye");
  }
  /// The view's and the lights' uniforms (the program in use).
  void set_view(const View& view, const Lighting& light) const {
    const Eigen::Matrix4f clip = view.clip_from_world();
    glUniformMatrix4fv(clip_from_world, 1, GL_FALSE, clip.data());
    const Eigen::Vector3f key = light.to_key_light.normalized();
    glUniform3fv(to_key_light, 1, key.data());
    glUniform3fv(key_color, 1, light.key_color.data());
    glUniform3fv(ambient, 1, light.ambient.data());
    const Eigen::Vector4f point(light.point_position.x(), light.point_position.y(),
                                light.point_position.z(),
                                light.point_light ? light.point_range_m : 0);
    glUniform4fv(point_light, 1, point.data());
    glUniform3fv(point_color, 1, light.point_color.data());
    const Eigen::Vector3f e = view.world_from_view.translation.cast<float>();
    glUniform3fv(eye, 1, e.data());
  }
};

}  // namespace volcast::gl
