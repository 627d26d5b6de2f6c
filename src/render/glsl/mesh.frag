// Mesh: the surface's colour, or colour x weight when blended.
#include "blend_fragment.glsl"
in vec4 v_color;
in float v_weight;
void main() {
#ifdef VOLCAST_PICK
  frag_color = window_depth_rgb();
  return;
#endif
  if (accumulate)
    write_blended(v_color.rgb, v_weight);
  else
    frag_color = v_color;
}
