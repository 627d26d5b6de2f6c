// Blending, step 3: colour = sum(colour x weight) / sum(weight) into the target. The depth
// written: with weighting 0 (v1) the prepass's (the front surface pushed back); with 1
// (reliability) the blended surface's (the weighted mean view depth, on the pixel's ray).
BINDING(0) uniform sampler2D accumulated;    // RGBA16F: rgb x weight, weight
BINDING(1) uniform sampler2D front_depth;    // the prepass's depth
BINDING(2) uniform sampler2D blended_depth;  // RG32F (browser: RG16F): view depth x weight, weight
uniform ivec2 origin;           // the viewport's lower left in the target
uniform int weighting;          // 0 angle and distance (v1), 1 reliability
uniform vec2 viewport_size;     // pixels
uniform mat4 view_from_clip;
uniform mat4 clip_from_view;
out vec4 frag_color;
vec3 view_point(vec2 ndc, float ndc_z) {
  vec4 p = view_from_clip * vec4(ndc, ndc_z, 1.0);
  return p.xyz / p.w;
}
void main() {
  ivec2 px = ivec2(gl_FragCoord.xy) - origin;
  vec4 a = texelFetch(accumulated, px, 0);
  if (a.a <= 0.0) discard;
  frag_color = vec4(a.rgb / a.a, 1.0);
  if (weighting == 0) {
    gl_FragDepth = texelFetch(front_depth, px, 0).r;
    return;
  }
  vec2 d = texelFetch(blended_depth, px, 0).rg;
  vec2 ndc = (vec2(px) + 0.5) / viewport_size * 2.0 - 1.0;
  vec3 near = view_point(ndc, -1.0), far = view_point(ndc, 1.0);
  vec3 p = mix(near, far, (-d.x / d.y - near.z) / (far.z - near.z));
  vec4 c = clip_from_view * vec4(p, 1.0);
  gl_FragDepth = clamp(c.z / c.w * 0.5 + 0.5, 0.0, 1.0);
}
