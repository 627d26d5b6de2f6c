// Mesh, step 1 (native, once per camera image, filter or threshold, not per draw): the kept
// triangles (mesh_triangles.glsl), compacted into an index buffer with an indirect draw command;
// a vertex's index is its depth pixel's, y * width + x.
#include "camera.glsl"
#include "mesh_triangles.glsl"
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) buffer Command {  // DrawElementsIndirectCommand
  uint count;
  uint instance_count;
  uint first_index;
  int base_vertex;
  uint base_instance;
} command;
layout(std430, binding = 1) writeonly buffer Indices { uint indices[]; };
uint index_of(ivec2 px) {
  return uint(px.y * size.x + px.x);
}
void main() {
  ivec2 q = ivec2(gl_GlobalInvocationID.xy);
  if (q.x >= size.x - 1 || q.y >= size.y - 1) return;
  for (int t = 0; t < 2; ++t) {
    if (!triangle_kept(q, t)) continue;
    uint i = atomicAdd(command.count, 3u);
    for (int k = 0; k < 3; ++k) indices[i + uint(k)] = index_of(triangle_corner(q, t, k));
  }
}
