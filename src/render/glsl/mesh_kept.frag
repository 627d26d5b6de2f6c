// Mesh, step 1 in the browser (WebGL2 has no compute shaders; once per camera image, filter or
// threshold, drawn over the (width - 1) x (height - 1) quads): which of quad q's two triangles
// are kept (mesh_triangles.glsl), bit t for triangle t, into an R8UI image that mesh.vert reads.
#include "camera.glsl"
#include "mesh_triangles.glsl"
layout(location = 0) out uint kept_out;
void main() {
  ivec2 q = ivec2(gl_FragCoord.xy);
  kept_out = (triangle_kept(q, 0) ? 1u : 0u) | (triangle_kept(q, 1) ? 2u : 0u);
}
