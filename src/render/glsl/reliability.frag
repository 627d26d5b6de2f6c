// Reliability, step 3: the chessboard distance to the nearest edge (the rows' distances, down
// the column), and the reliability image (RG16F): confidence, w_edge = smoothstep of that
// distance over radius + 1; 0, 0 where there is no point.
#include "camera.glsl"
BINDING(5) uniform usampler2D across;
uniform int radius;
layout(location = 0) out vec2 reliability_out;
void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  vec3 p;
  if (!camera_point(px, p)) {
    reliability_out = vec2(0.0);
    return;
  }
  uint best = uint(radius + 1);
  for (int dy = -radius; dy <= radius; ++dy) {
    int y = px.y + dy;
    if (y >= 0 && y < size.y)
      best = min(best, max(uint(abs(dy)), texelFetch(across, ivec2(px.x, y), 0).r));
  }
  float edge = smoothstep(0.0, 1.0, float(best) / float(radius + 1));
  reliability_out = vec2(confidence(px, p), edge);
}
