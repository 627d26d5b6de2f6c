// The avatar filter (volcast/render/avatar_filter.hpp): a point (metres, the points' frame) is
// hidden outside the keep sphere, or inside the box about the headset.
uniform vec4 keep_sphere;       // centre (metres), radius; radius <= 0: off
uniform mat4 headset_from_points;
uniform vec3 hide_half_extent;  // metres; x <= 0: off
bool avatar_hidden(vec3 p) {
  vec3 d = p - keep_sphere.xyz;
  if (keep_sphere.w > 0.0 && dot(d, d) > keep_sphere.w * keep_sphere.w) return true;
  if (hide_half_extent.x <= 0.0) return false;
  vec3 h = abs((headset_from_points * vec4(p, 1.0)).xyz);
  return all(lessThanEqual(h, hide_half_extent));
}
