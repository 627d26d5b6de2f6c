// Reliability, step 2: the distance (pixels) to the nearest edge in the same row, up to radius
// (radius + 1: none within it). Into an R8UI image.
BINDING(0) uniform usampler2D edges;
uniform ivec2 size;
uniform int radius;
layout(location = 0) out uint across_out;
void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  uint best = uint(radius + 1);
  for (int dx = -radius; dx <= radius; ++dx) {
    int x = px.x + dx;
    if (x >= 0 && x < size.x && texelFetch(edges, ivec2(x, px.y), 0).r != 0u)
      best = min(best, uint(abs(dx)));
  }
  across_out = best;
}
