// Splats: round, weighted towards their centre when blended.
#include "blend_fragment.glsl"
in vec4 v_color;
in float v_weight;
void main() {
  vec2 c = gl_PointCoord * 2.0 - 1.0;
  float r2 = dot(c, c);
  if (r2 > 1.0) discard;  // round splats
#ifdef VOLCAST_PICK
  frag_color = window_depth_rgb();
  return;
#endif
  if (accumulate) {
    write_blended(v_color.rgb, v_weight * max(1.0 - r2, 0.02));
  } else {
    frag_color = v_color;
  }
}
