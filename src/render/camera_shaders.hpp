#pragma once
// GLSL of CameraRenderer (internal to src/render; see camera_renderer.hpp for what each pass does).
#include "gl_util.hpp"

namespace volcast::shaders {

// Declarations and helpers every camera program shares: the camera's textures, where it sits, and
// how a depth pixel becomes a point, a color and a blending weight.
#define VOLCAST_CAMERA_COMMON_GLSL                                                               \
  "#version 450 core\n" VOLCAST_AVATAR_FILTER_GLSL                                               \
  "layout(binding = 0) uniform usampler2D depth_mm;  /* R16UI, 0 = invalid */\n"                 \
  "layout(binding = 1) uniform sampler2D rays;       /* RG32F X/Z, Y/Z; NaN: no ray */\n"        \
  "layout(binding = 2) uniform sampler2D color_tex;  /* RGBA8, registered to depth */\n"         \
  "uniform bool has_color;\n"                                                                    \
  "uniform ivec2 size;               /* depth image, pixels */\n"                                \
  "uniform mat4 view_from_camera;\n"                                                             \
  "uniform mat4 clip_from_view;\n"                                                               \
  "uniform vec4 tint;                /* rgb, strength */\n"                                      \
  "uniform float depth_push;         /* metres away from the eye (blend prepass), or 0 */\n"     \
  "uniform bool accumulate;          /* blend pass: write color x weight, weight */\n"           \
  "layout(binding = 3) uniform sampler2D reliability; /* RG16F: confidence, edge 0..1 */\n"      \
  "uniform int weighting;            /* 0 angle and distance (v1), 1 reliability */\n"           \
  "uniform float erode_push;         /* metres, the prepass's push of an edge pixel */\n"        \
  "uniform vec3 gain;                /* this camera's colour balance */\n"                       \
  "float extra_push = 0.0;           /* metres, set per vertex: erosion */\n"                    \
  "bool camera_point(ivec2 px, out vec3 p) {\n"                                                  \
  "  p = vec3(0.0);\n"                                                                           \
  "  if (any(lessThan(px, ivec2(0))) || any(greaterThanEqual(px, size))) return false;\n"        \
  "  uint d = texelFetch(depth_mm, px, 0).r;\n"                                                  \
  "  vec2 ray = texelFetch(rays, px, 0).rg;\n"                                                   \
  "  if (d == 0u || isnan(ray.x)) return false;\n"                                               \
  "  float z = float(d) * 0.001;\n"                                                              \
  "  p = vec3(ray * z, z);\n"                                                                    \
  "  return true;\n"                                                                             \
  "}\n"                                                                                          \
  "vec4 clip_of(vec3 p_camera) {\n"                                                              \
  "  vec3 v = (view_from_camera * vec4(p_camera, 1.0)).xyz;\n"                                   \
  "  if (depth_push > 0.0) v += normalize(v) * (depth_push + extra_push);\n"                     \
  "  return clip_from_view * vec4(v, 1.0);\n"                                                    \
  "}\n"                                                                                          \
  "vec3 shaded(ivec2 px) {\n"                                                                    \
  "  vec4 c = texelFetch(color_tex, px, 0);\n"                                                   \
  "  vec3 base = has_color && c.a > 0.0 ? min(c.rgb * gain, vec3(1.0)) : vec3(160.0 / 255.0);\n" \
  "  return mix(base, tint.rgb, tint.a);\n"                                                      \
  "}\n"                                                                                          \
  "bool near_point(ivec2 px, vec3 p0, out vec3 p) {\n"                                           \
  "  return camera_point(px, p) && abs(p.z - p0.z) <= 0.1 * p0.z;\n"                             \
  "}\n"                                                                                          \
  "float confidence(ivec2 px, vec3 p) {  /* cos(normal, ray) >= 0.05, over z^2 */\n"             \
  "  vec3 l, r, u, d;\n"                                                                         \
  "  vec3 dx = (near_point(px + ivec2(1, 0), p, r) ? r : p) -\n"                                 \
  "            (near_point(px - ivec2(1, 0), p, l) ? l : p);\n"                                  \
  "  vec3 dy = (near_point(px + ivec2(0, 1), p, d) ? d : p) -\n"                                 \
  "            (near_point(px - ivec2(0, 1), p, u) ? u : p);\n"                                  \
  "  vec3 n = cross(dx, dy);\n"                                                                  \
  "  float c = dot(n, n) > 0.0 ? abs(dot(normalize(n), normalize(p))) : 1.0;\n"                  \
  "  return max(c, 0.05) / (p.z * p.z);\n"                                                       \
  "}\n"                                                                                          \
  "/* A blended sample's weight: v1's confidence, or the reliability pass's (its confidence\n"   \
  "   x how far the pixel lies from a depth edge, and none for a pixel the camera's colour\n"    \
  "   did not reach); sets extra_push in the prepass. */\n"                                      \
  "float blend_weight(ivec2 px, vec3 p) {\n"                                                     \
  "  if (weighting == 0) return accumulate ? confidence(px, p) : 1.0;\n"                         \
  "  vec2 r = texelFetch(reliability, px, 0).rg;\n"                                              \
  "  float trust = !has_color || texelFetch(color_tex, px, 0).a > 0.0 ? r.g : 0.0;\n"            \
  "  if (depth_push > 0.0) extra_push = erode_push * (1.0 - trust);\n"                           \
  "  return r.r * max(trust, 0.02);\n"                                                           \
  "}\n"

// What the splat and mesh fragments share: in the blending pass, the soft depth tolerance
// (kReliability) and the second target, view depth x weight, from which the resolve writes the
// blended surface's depth.
#define VOLCAST_BLEND_FRAGMENT_GLSL                                                              \
  "#version 450 core\n"                                                                          \
  "uniform bool accumulate;\n"                                                                   \
  "uniform int weighting;            /* 0 angle and distance (v1), 1 reliability */\n"           \
  "layout(binding = 4) uniform sampler2D front_depth;  /* a copy of the prepass's */\n"          \
  "uniform mat4 view_from_clip;\n"                                                               \
  "uniform vec2 viewport_size;       /* the blending framebuffer's, pixels */\n"                 \
  "uniform float blend_push;         /* metres: blend_depth_m */\n"                              \
  "layout(location = 0) out vec4 frag_color;\n"                                                  \
  "layout(location = 1) out vec2 frag_depth;  /* view depth x weight, weight */\n"               \
  "vec3 view_point(vec2 ndc, float ndc_z) {\n"                                                   \
  "  vec4 p = view_from_clip * vec4(ndc, ndc_z, 1.0);\n"                                         \
  "  return p.xyz / p.w;\n"                                                                      \
  "}\n"                                                                                          \
  "void write_blended(vec3 rgb, float w) {\n"                                                    \
  "  vec2 ndc = gl_FragCoord.xy / viewport_size * 2.0 - 1.0;\n"                                  \
  "  vec3 here = view_point(ndc, gl_FragCoord.z * 2.0 - 1.0);\n"                                 \
  "  if (weighting == 1) {\n"                                                                    \
  "    vec3 dir = normalize(view_point(ndc, 1.0) - view_point(ndc, -1.0));\n"                    \
  "    float front = texelFetch(front_depth, ivec2(gl_FragCoord.xy), 0).r;\n"                    \
  "    vec3 f = view_point(ndc, front * 2.0 - 1.0);\n"                                           \
  "    /* how far behind the front surface (the prepass's depth less its push), on the ray */\n" \
  "    float behind = dot(here - f, dir) + blend_push;\n"                                        \
  "    w = max(w * (1.0 - smoothstep(blend_push / 3.0, blend_push, behind)), 1e-4);\n"           \
  "  }\n"                                                                                        \
  "  frag_color = vec4(rgb * w, w);\n"                                                           \
  "  frag_depth = vec2(-here.z * w, w);\n"                                                       \
  "}\n"

// Splats: vertex gl_VertexID is depth pixel (id % width, id / width).
inline constexpr const char* kSplatVertex = VOLCAST_CAMERA_COMMON_GLSL R"(
uniform int size_mode;           // 0 fixed pixels, 1 footprint, 2 adaptive
uniform float fixed_px;
uniform float radius_per_metre;  // footprint radius per metre of depth, x splat_scale
uniform float splat_scale;
uniform float pixels_per_unit;   // viewport_height / 2 * clip_from_view[1][1]
uniform vec2 half_viewport;      // viewport width / 2, height / 2, pixels
out vec4 v_color;
out float v_weight;
// Screen distance (pixels) from s, where p lands, to the nearest valid pixel on the same surface
// 1 to 3 steps away along `step`; 0 when there is none.
float neighbour_gap(ivec2 px, vec3 p, vec2 s, ivec2 step) {
  for (int k = 1; k <= 3; ++k) {
    vec3 q;
    if (near_point(px + k * step, p, q)) {
      const vec4 c = clip_of(q);
      return distance(c.xy / c.w * half_viewport, s);
    }
  }
  return 0.0;
}
void main() {
  const ivec2 px = ivec2(gl_VertexID % size.x, gl_VertexID / size.x);
  vec3 p;
  if (!camera_point(px, p) || avatar_hidden(p)) {
    gl_Position = vec4(0.0, 0.0, 2.0, 1.0);  // beyond the far plane: clipped, nothing drawn
    gl_PointSize = 1.0;
    v_color = vec4(0.0);
    v_weight = 0.0;
    return;
  }
  v_weight = blend_weight(px, p);  // before clip_of: it sets the prepass's erosion push
  gl_Position = clip_of(p);
  float size_px = fixed_px;
  if (size_mode != 0) {
    // The footprint: radius_per_metre x depth, projected.
    size_px = 2.0 * p.z * radius_per_metre * pixels_per_unit / gl_Position.w;
    if (size_mode == 2) {
      // Adaptive: cover the gap to the nearest valid neighbours on the same surface.
      const vec2 s = gl_Position.xy / gl_Position.w * half_viewport;
      const float gx = max(neighbour_gap(px, p, s, ivec2(1, 0)), neighbour_gap(px, p, s, ivec2(-1, 0)));
      const float gy = max(neighbour_gap(px, p, s, ivec2(0, 1)), neighbour_gap(px, p, s, ivec2(0, -1)));
      const float cover = length(vec2(gx, gy)) * splat_scale;
      if (cover > 0.0) size_px = min(max(cover, size_px), 4.0 * size_px);
    }
  }
  gl_PointSize = clamp(size_px, 1.0, 64.0);
  v_color = vec4(shaded(px), 1.0);
}
)";

inline constexpr const char* kSplatFragment = VOLCAST_BLEND_FRAGMENT_GLSL R"(
in vec4 v_color;
in float v_weight;
void main() {
  const vec2 c = gl_PointCoord * 2.0 - 1.0;
  const float r2 = dot(c, c);
  if (r2 > 1.0) discard;  // round splats
  if (accumulate) {
    write_blended(v_color.rgb, v_weight * max(1.0 - r2, 0.02));
  } else {
    frag_color = v_color;
  }
}
)";

// Mesh, step 1 (once per camera image, filter or threshold, not per draw): the triangles to
// draw, compacted into an index buffer with an indirect draw command. Quad (x, y) of the depth
// grid makes triangles (x,y)-(x,y+1)-(x+1,y) and (x+1,y)-(x,y+1)-(x+1,y+1); one is kept when its
// three corners are valid points the avatar filter keeps and no edge is longer than
// max_edge_ratio x the depth of its nearer end.
inline constexpr const char* kMeshIndices = "#version 450 core\n" VOLCAST_AVATAR_FILTER_GLSL R"(
layout(local_size_x = 16, local_size_y = 16) in;
layout(binding = 0) uniform usampler2D depth_mm;
layout(binding = 1) uniform sampler2D rays;
uniform ivec2 size;
uniform float max_edge_ratio;
layout(std430, binding = 0) buffer Command {  // DrawElementsIndirectCommand
  uint count;
  uint instance_count;
  uint first_index;
  int base_vertex;
  uint base_instance;
} command;
layout(std430, binding = 1) writeonly buffer Indices { uint indices[]; };
bool point_at(ivec2 px, out vec3 p) {
  const uint d = texelFetch(depth_mm, px, 0).r;
  const vec2 ray = texelFetch(rays, px, 0).rg;
  p = vec3(ray * (float(d) * 0.001), float(d) * 0.001);
  return d != 0u && !isnan(ray.x) && !avatar_hidden(p);
}
bool long_edge(vec3 a, vec3 b) {
  return distance(a, b) > max_edge_ratio * min(a.z, b.z);
}
bool keep(vec3 a, vec3 b, vec3 c) {
  return !long_edge(a, b) && !long_edge(b, c) && !long_edge(c, a);
}
void emit(uint a, uint b, uint c) {
  const uint i = atomicAdd(command.count, 3u);
  indices[i] = a;
  indices[i + 1u] = b;
  indices[i + 2u] = c;
}
void main() {
  const ivec2 q = ivec2(gl_GlobalInvocationID.xy);
  if (q.x >= size.x - 1 || q.y >= size.y - 1) return;
  vec3 p00, p10, p01, p11;
  const bool v00 = point_at(q, p00), v10 = point_at(q + ivec2(1, 0), p10),
             v01 = point_at(q + ivec2(0, 1), p01), v11 = point_at(q + ivec2(1, 1), p11);
  const uint i00 = uint(q.y * size.x + q.x), i10 = i00 + 1u, i01 = i00 + uint(size.x),
             i11 = i01 + 1u;
  if (v00 && v01 && v10 && keep(p00, p01, p10)) emit(i00, i01, i10);
  if (v10 && v01 && v11 && keep(p10, p01, p11)) emit(i10, i01, i11);
}
)";

// Mesh, step 2 (every draw): the kept triangles' corners, indexed by depth pixel
// (index = y * width + x).
inline constexpr const char* kMeshVertex = VOLCAST_CAMERA_COMMON_GLSL R"(
out vec4 v_color;
out float v_weight;
void main() {
  const ivec2 px = ivec2(gl_VertexID % size.x, gl_VertexID / size.x);
  vec3 p;
  camera_point(px, p);  // valid: step 1 kept only triangles of valid corners
  v_color = vec4(shaded(px), 1.0);
  v_weight = blend_weight(px, p);  // before clip_of: it sets the prepass's erosion push
  gl_Position = clip_of(p);
}
)";

inline constexpr const char* kMeshFragment = VOLCAST_BLEND_FRAGMENT_GLSL R"(
in vec4 v_color;
in float v_weight;
void main() {
  if (accumulate)
    write_blended(v_color.rgb, v_weight);
  else
    frag_color = v_color;
}
)";

// Resolve: one triangle over the viewport; color = sum(color x weight) / sum(weight).
inline constexpr const char* kResolveVertex = R"(#version 450 core
void main() {
  const vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
)";

// The depth written: kAngleDistance, the prepass's (the front surface pushed back);
// kReliability, the blended surface's (the weighted mean view depth, on the pixel's ray).
inline constexpr const char* kResolveFragment = R"(#version 450 core
layout(binding = 0) uniform sampler2D accumulated;  // RGBA16F: rgb x weight, weight
layout(binding = 1) uniform sampler2D front_depth;  // the prepass's depth
layout(binding = 2) uniform sampler2D blended_depth; // RG32F: view depth x weight, weight
uniform ivec2 origin;                                // the viewport's lower left in the target
uniform int weighting;                               // 0 angle and distance (v1), 1 reliability
uniform vec2 viewport_size;                          // pixels
uniform mat4 view_from_clip;
uniform mat4 clip_from_view;
out vec4 frag_color;
vec3 view_point(vec2 ndc, float ndc_z) {
  const vec4 p = view_from_clip * vec4(ndc, ndc_z, 1.0);
  return p.xyz / p.w;
}
void main() {
  const ivec2 px = ivec2(gl_FragCoord.xy) - origin;
  const vec4 a = texelFetch(accumulated, px, 0);
  if (a.a <= 0.0) discard;
  frag_color = vec4(a.rgb / a.a, 1.0);
  if (weighting == 0) {
    gl_FragDepth = texelFetch(front_depth, px, 0).r;
    return;
  }
  const vec2 d = texelFetch(blended_depth, px, 0).rg;
  const vec2 ndc = (vec2(px) + 0.5) / viewport_size * 2.0 - 1.0;
  const vec3 near = view_point(ndc, -1.0), far = view_point(ndc, 1.0);
  const vec3 p = mix(near, far, (-d.x / d.y - near.z) / (far.z - near.z));
  const vec4 c = clip_from_view * vec4(p, 1.0);
  gl_FragDepth = clamp(c.z / c.w * 0.5 + 0.5, 0.0, 1.0);
}
)";

// Reliability, step 1 (once per camera image): depth edges -- an invalid pixel, or one with a
// 4-neighbour outside the image, invalid, or more than edge_step x its depth away.
inline constexpr const char* kEdges = R"(#version 450 core
layout(local_size_x = 16, local_size_y = 16) in;
layout(binding = 0) uniform usampler2D depth_mm;
layout(binding = 1) uniform sampler2D rays;
layout(r8ui, binding = 0) uniform writeonly uimage2D edges;
uniform ivec2 size;
uniform float edge_step;
float z_at(ivec2 px) {  // metres, or -1: none
  if (any(lessThan(px, ivec2(0))) || any(greaterThanEqual(px, size))) return -1.0;
  const uint d = texelFetch(depth_mm, px, 0).r;
  return d == 0u || isnan(texelFetch(rays, px, 0).r) ? -1.0 : float(d) * 0.001;
}
void main() {
  const ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(px, size))) return;
  const float z = z_at(px);
  bool edge = z < 0.0;
  const ivec2 around[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
  for (int i = 0; i < 4 && !edge; ++i) {
    const float q = z_at(px + around[i]);
    edge = q < 0.0 || abs(q - z) > edge_step * z;
  }
  imageStore(edges, px, uvec4(edge ? 1u : 0u));
}
)";

// Reliability, step 2: the distance (pixels) to the nearest edge in the same row, up to radius
// (radius + 1: none within it).
inline constexpr const char* kEdgeRows = R"(#version 450 core
layout(local_size_x = 16, local_size_y = 16) in;
layout(binding = 0) uniform usampler2D edges;
layout(r8ui, binding = 0) uniform writeonly uimage2D across;
uniform ivec2 size;
uniform int radius;
void main() {
  const ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(px, size))) return;
  uint best = uint(radius + 1);
  for (int dx = -radius; dx <= radius; ++dx) {
    const int x = px.x + dx;
    if (x >= 0 && x < size.x && texelFetch(edges, ivec2(x, px.y), 0).r != 0u)
      best = min(best, uint(abs(dx)));
  }
  imageStore(across, px, uvec4(best));
}
)";

// Reliability, step 3: the chessboard distance to the nearest edge (the rows' distances, down
// the column), and the reliability texture: (confidence, w_edge).
inline constexpr const char* kReliability = VOLCAST_CAMERA_COMMON_GLSL R"(
layout(local_size_x = 16, local_size_y = 16) in;
layout(binding = 5) uniform usampler2D across;
layout(rg16f, binding = 0) uniform writeonly image2D reliability_out;
uniform int radius;
void main() {
  const ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(px, size))) return;
  vec3 p;
  if (!camera_point(px, p)) {
    imageStore(reliability_out, px, vec4(0.0));
    return;
  }
  uint best = uint(radius + 1);
  for (int dy = -radius; dy <= radius; ++dy) {
    const int y = px.y + dy;
    if (y >= 0 && y < size.y)
      best = min(best, max(uint(abs(dy)), texelFetch(across, ivec2(px.x, y), 0).r));
  }
  const float edge = smoothstep(0.0, 1.0, float(best) / float(radius + 1));
  imageStore(reliability_out, px, vec4(confidence(px, p), edge, 0.0, 0.0));
}
)";

}  // namespace volcast::shaders
