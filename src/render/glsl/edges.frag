// Reliability, step 1 (once per camera image, drawn over the depth image): depth edges -- an
// invalid pixel, or one with a 4-neighbour outside the image, invalid, or more than edge_step x
// its depth away. Into an R8UI image: 1 edge, 0 not.
#include "camera.glsl"
uniform float edge_step;
layout(location = 0) out uint edge_out;
float z_at(ivec2 px) {  // metres, or -1: none
  vec3 p;
  return camera_point(px, p) ? p.z : -1.0;
}
void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  float z = z_at(px);
  bool edge = z < 0.0;
  ivec2 around[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
  for (int i = 0; i < 4 && !edge; ++i) {
    float q = z_at(px + around[i]);
    edge = q < 0.0 || abs(q - z) > edge_step * z;
  }
  edge_out = edge ? 1u : 0u;
}
