// What the splat and mesh fragments share: in the blending pass, the soft depth tolerance
// (reliability weighting) and the second target, view depth x weight, from which the resolve
// writes the blended surface's depth.
uniform bool accumulate;
uniform int weighting;          // 0 angle and distance (v1), 1 reliability
BINDING(4) uniform sampler2D front_depth;  // a copy of the prepass's depth
uniform mat4 clip_from_view;    // perspective (symmetric or off-centre) or orthographic
uniform vec2 viewport_size;     // the blending framebuffer's, pixels
uniform float blend_push;       // metres: blend_depth_m
layout(location = 0) out vec4 frag_color;
layout(location = 1) out vec2 frag_depth;  // view depth x weight, weight
// The view depth (metres, along -z) of window depth window_z. Only z reaches clip z and w:
// clip.z = A z + B, clip.w = C z + D, so -z = (ndc_z D - B) / (ndc_z C - A) (view_depth_m).
float view_depth(float window_z) {
  float ndc_z = window_z * 2.0 - 1.0;
  return (ndc_z * clip_from_view[3][3] - clip_from_view[3][2]) /
         (ndc_z * clip_from_view[2][3] - clip_from_view[2][2]);
}
void write_blended(vec3 rgb, float w) {
  float here = view_depth(gl_FragCoord.z);
  if (weighting == 1) {
    // This pixel's ray length per metre of view depth: for a perspective, (x, y) / depth =
    // (ndc + P[2].xy) / (P[0][0], P[1][1]); for an orthographic view the rays run along -z.
    vec2 ndc = gl_FragCoord.xy / viewport_size * 2.0 - 1.0;
    vec2 xy = (ndc + clip_from_view[2].xy) / vec2(clip_from_view[0][0], clip_from_view[1][1]);
    float per_metre = clip_from_view[2][3] != 0.0 ? length(vec3(xy, 1.0)) : 1.0;
    float front = view_depth(texelFetch(front_depth, ivec2(gl_FragCoord.xy), 0).r);
    // how far behind the front surface (the prepass's depth less its push), on the ray
    float behind = (here - front) * per_metre + blend_push;
    w = max(w * (1.0 - smoothstep(blend_push / 3.0, blend_push, behind)), 1e-4);
  }
  frag_color = vec4(rgb * w, w);
  frag_depth = vec2(here * w, w);
}
#ifdef VOLCAST_PICK
// The browser's pick pass (renderer.js pick): the fragment's window depth, 24 bits in rgb.
vec4 window_depth_rgb() {
  highp uint d = uint(clamp(gl_FragCoord.z, 0.0, 1.0) * 16777215.0);
  return vec4(float(d >> 16u), float((d >> 8u) & 255u), float(d & 255u), 255.0) / 255.0;
}
#endif
