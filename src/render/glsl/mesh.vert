// Mesh, step 2 (every draw): the kept triangles' corners. Native: indexed by depth pixel (the
// index buffer of mesh_indices.comp). Browser (VOLCAST_MESH_BY_TRIANGLE): every candidate
// triangle's three vertices in turn, vertex (quad x 2 + t) x 3 + k, dropped together unless
// mesh_kept.frag kept triangle t of the quad.
#include "camera.glsl"
#include "mesh_triangles.glsl"
#ifdef VOLCAST_MESH_BY_TRIANGLE
BINDING(6) uniform usampler2D kept_triangles;  // R8UI per quad: bit t, triangle t kept
#endif
out vec4 v_color;
out float v_weight;
void main() {
#ifdef VOLCAST_MESH_BY_TRIANGLE
  int t = gl_VertexID / 3;
  ivec2 q = ivec2((t / 2) % (size.x - 1), (t / 2) / (size.x - 1));
  if (((texelFetch(kept_triangles, q, 0).r >> uint(t % 2)) & 1u) == 0u) {
    gl_Position = vec4(0.0, 0.0, 2.0, 1.0);  // beyond the far plane: clipped, nothing drawn
    v_color = vec4(0.0);
    v_weight = 0.0;
    return;
  }
  ivec2 px = triangle_corner(q, t % 2, gl_VertexID % 3);
#else
  ivec2 px = ivec2(gl_VertexID % size.x, gl_VertexID / size.x);
#endif
  vec3 p;
  camera_point(px, p);  // valid: only triangles of valid corners are drawn
  v_color = vec4(shaded(px), 1.0);
  v_weight = blend_weight(px, p);  // before clip_of: it sets the prepass's erosion push
  gl_Position = clip_of(p);
}
