// Splats: vertex gl_VertexID is depth pixel (id % width, id / width).
#include "camera.glsl"
uniform int size_mode;           // 0 fixed pixels, 1 footprint, 2 adaptive
uniform float fixed_px;
uniform float radius_per_metre;  // footprint radius per metre of depth, x splat_scale
uniform float splat_scale;
uniform float pixels_per_unit;   // viewport_height / 2 * clip_from_view[1][1]
uniform vec2 half_viewport;      // viewport width / 2, height / 2, pixels
out vec4 v_color;
out float v_weight;
// Screen distance (pixels) from s, where p lands, to the nearest valid pixel on the same surface
// 1 to 3 steps away along step; 0 when there is none.
float neighbour_gap(ivec2 px, vec3 p, vec2 s, ivec2 step) {
  for (int k = 1; k <= 3; ++k) {
    vec3 q;
    if (near_point(px + k * step, p, q)) {
      vec4 c = clip_of(q);
      return distance(c.xy / c.w * half_viewport, s);
    }
  }
  return 0.0;
}
void main() {
  ivec2 px = ivec2(gl_VertexID % size.x, gl_VertexID / size.x);
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
      vec2 s = gl_Position.xy / gl_Position.w * half_viewport;
      float gx = max(neighbour_gap(px, p, s, ivec2(1, 0)), neighbour_gap(px, p, s, ivec2(-1, 0)));
      float gy = max(neighbour_gap(px, p, s, ivec2(0, 1)), neighbour_gap(px, p, s, ivec2(0, -1)));
      float cover = length(vec2(gx, gy)) * splat_scale;
      if (cover > 0.0) size_px = min(max(cover, size_px), 4.0 * size_px);
    }
  }
  gl_PointSize = clamp(size_px, 1.0, 64.0);
  v_color = vec4(shaded(px), 1.0);
}
