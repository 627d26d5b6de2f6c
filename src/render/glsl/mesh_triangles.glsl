// The grid mesh's triangles. Quad q = (x, y) of the depth grid makes triangles 0: (x,y)-(x,y+1)-
// (x+1,y) and 1: (x+1,y)-(x,y+1)-(x+1,y+1); one is kept when its three corners are valid points
// the avatar filter keeps and no edge is longer than max_edge_ratio x the depth of its nearer end.
uniform float max_edge_ratio;
bool mesh_point(ivec2 px, out vec3 p) {
  return camera_point(px, p) && !avatar_hidden(p);
}
bool long_edge(vec3 a, vec3 b) {
  return distance(a, b) > max_edge_ratio * min(a.z, b.z);
}
// Corner k (0..2) of triangle t (0, 1) of quad q: a depth pixel.
ivec2 triangle_corner(ivec2 q, int t, int k) {
  if (k == 1) return q + ivec2(0, 1);
  if (t == 0) return q + (k == 0 ? ivec2(0, 0) : ivec2(1, 0));
  return q + (k == 0 ? ivec2(1, 0) : ivec2(1, 1));
}
bool triangle_kept(ivec2 q, int t) {
  vec3 a, b, c;
  return mesh_point(triangle_corner(q, t, 0), a) && mesh_point(triangle_corner(q, t, 1), b) &&
         mesh_point(triangle_corner(q, t, 2), c) && !long_edge(a, b) && !long_edge(b, c) &&
         !long_edge(c, a);
}
