// Declarations and helpers every camera program shares: the camera's textures, where it sits,
// and how a depth pixel becomes a point (camera frame, metres), a colour and a blending weight.
#include "avatar_filter.glsl"
BINDING(0) uniform usampler2D depth_mm;    // R16UI, millimetres, 0 = invalid
BINDING(1) uniform sampler2D rays;         // RG32F X/Z, Y/Z; NaN: no ray
BINDING(2) uniform sampler2D color_tex;    // RGBA8, registered to depth; alpha 0: not reached
BINDING(3) uniform sampler2D reliability;  // RG16F: confidence, w_edge 0..1 (reliability.frag)
uniform bool has_color;
uniform ivec2 size;             // depth image, pixels
uniform mat4 view_from_camera;
uniform mat4 clip_from_view;
uniform vec4 tint;              // rgb, strength
uniform float depth_push;       // metres away from the eye (blend prepass), or 0
uniform bool accumulate;        // blend pass: write colour x weight, weight
uniform int weighting;          // 0 angle and distance (v1), 1 reliability
uniform float erode_push;       // metres, the prepass's push of an edge pixel
uniform vec3 gain;              // this camera's colour balance
float extra_push = 0.0;         // metres, set per vertex: erosion
bool camera_point(ivec2 px, out vec3 p) {
  p = vec3(0.0);
  if (any(lessThan(px, ivec2(0))) || any(greaterThanEqual(px, size))) return false;
  uint d = texelFetch(depth_mm, px, 0).r;
  vec2 ray = texelFetch(rays, px, 0).rg;
  if (d == 0u || isnan(ray.x)) return false;
  float z = float(d) * 0.001;
  p = vec3(ray * z, z);
  return true;
}
vec4 clip_of(vec3 p_camera) {
  vec3 v = (view_from_camera * vec4(p_camera, 1.0)).xyz;
  if (depth_push > 0.0) v += normalize(v) * (depth_push + extra_push);
  return clip_from_view * vec4(v, 1.0);
}
vec3 shaded(ivec2 px) {
  vec4 c = texelFetch(color_tex, px, 0);
  vec3 base = has_color && c.a > 0.0 ? min(c.rgb * gain, vec3(1.0)) : vec3(160.0 / 255.0);
  return mix(base, tint.rgb, tint.a);
}
bool near_point(ivec2 px, vec3 p0, out vec3 p) {
  return camera_point(px, p) && abs(p.z - p0.z) <= 0.1 * p0.z;
}
// cos(normal, ray) >= 0.05, over z^2.
float confidence(ivec2 px, vec3 p) {
  vec3 l, r, u, d;
  vec3 dx = (near_point(px + ivec2(1, 0), p, r) ? r : p) -
            (near_point(px - ivec2(1, 0), p, l) ? l : p);
  vec3 dy = (near_point(px + ivec2(0, 1), p, d) ? d : p) -
            (near_point(px - ivec2(0, 1), p, u) ? u : p);
  vec3 n = cross(dx, dy);
  float c = dot(n, n) > 0.0 ? abs(dot(normalize(n), normalize(p))) : 1.0;
  return max(c, 0.05) / (p.z * p.z);
}
// A blended sample's weight: v1's confidence, or the reliability pass's (its confidence x how
// far the pixel lies from a depth edge, and none for a pixel the camera's colour did not reach);
// sets extra_push in the prepass.
float blend_weight(ivec2 px, vec3 p) {
  if (weighting == 0) return accumulate ? confidence(px, p) : 1.0;
  vec2 r = texelFetch(reliability, px, 0).rg;
  float trust = !has_color || texelFetch(color_tex, px, 0).a > 0.0 ? r.g : 0.0;
  if (depth_push > 0.0) extra_push = erode_push * (1.0 - trust);
  return r.r * max(trust, 0.02);
}
