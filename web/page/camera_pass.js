// The browser's camera pass (renderer.js draws with it): the site's cameras and the camera
// avatars drawn with the native CameraRenderer's method and shaders
// (src/render/camera_renderer.hpp; one GLSL source, src/render/glsl, generated into
// camera_glsl.js): a grid mesh (the default) or splats, each depth pixel unprojected through the
// camera's ray table, overlapping cameras blended by reliability (depth-edge distance, angle,
// distance; erosion, a soft depth tolerance) through a prepass, a weighted pass into float
// targets and a resolve. A camera is a plain object (makeCamera) its owner keeps.
import * as glsl from './camera_glsl.js';
import {compile} from './gl_program.js';
import {apply, invert, multiply} from './math.js';

// GLSL ES 3.00's preamble for the shared camera shaders (src/render/glsl/README.md): the native
// renderer puts "#version 450 core" and BINDING(n) = layout(binding = n) first instead.
const ES_PREAMBLE = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp usampler2D;
#define BINDING(n)
`;

// The camera pass's settings, as the native CameraPassOptions' defaults
// (src/render/include/volcast/render/camera_renderer.hpp).
export const CAMERA_DEFAULTS = {
  surface: 'mesh',         // or 'splats'
  splatSize: 'adaptive',   // 'fixed', 'footprint' or 'adaptive'
  fixedPx: 2,              // splatSize 'fixed': pixels
  splatScale: 1,           // multiplies the footprint radius
  edgeRatio: 0.05,         // mesh: an edge longer than this x the nearer depth is dropped
  blend: true,             // blend overlapping cameras
  blendDepthM: 0.03,       // fragments this close behind the front surface are blended
  weighting: 'reliability', // or 'angle' (v1: angle and distance)
  edgePx: 4,               // reliability: w_edge reaches 1 this many pixels from an edge
  erodeDepthM: 0.1,        // reliability: the prepass's push of an edge pixel, metres
  balanceColour: true,     // the cameras' colour gains (setGains: the worker's colour balance)
};
const EDGE_STEP = 0.05;    // a 4-neighbour this much of the depth away is an edge (native kEdgeStep)
const SPLAT_SIZES = {fixed: 0, footprint: 1, adaptive: 2};

// A program of the shared camera shaders (camera_glsl.js) in GLSL ES 3.00, `defines` after the
// preamble; each sampler's unit is set to the n of its BINDING(n), as the native layout does.
function compileShared(gl, vs, fs, defines = []) {
  const head = ES_PREAMBLE + defines.map((d) => `#define ${d}\n`).join('');
  const p = compile(gl, head + vs, head + fs);
  gl.useProgram(p.program);
  for (const [, unit, name] of (vs + fs).matchAll(/BINDING\((\d+)\)\s+uniform\s+\w+\s+(\w+)/g))
    if (p.uniforms[name]) gl.uniform1i(p.uniforms[name], Number(unit));
  return p;
}

export class CameraPass {
  constructor(gl) {
    this.gl = gl;
    // Blending needs float colour targets (EXT_color_buffer_float: the Quest browser and desktop
    // Chromium have it); the blended depth's sums are RG32F with EXT_float_blend, else RG16F.
    this.floatTargets = !!gl.getExtension('EXT_color_buffer_float');
    this.floatBlend = !!gl.getExtension('EXT_float_blend');
    this.empty = gl.createVertexArray();  // the passes draw without vertex buffers
    const byTriangle = 'VOLCAST_MESH_BY_TRIANGLE';
    this.splat = compileShared(gl, glsl.splatVert, glsl.splatFrag);
    this.mesh = compileShared(gl, glsl.meshVert, glsl.meshFrag, [byTriangle]);
    this.splatPick = compileShared(gl, glsl.splatVert, glsl.splatFrag, ['VOLCAST_PICK']);
    this.meshPick = compileShared(gl, glsl.meshVert, glsl.meshFrag, [byTriangle, 'VOLCAST_PICK']);
    this.resolve = compileShared(gl, glsl.fullscreenVert, glsl.resolveFrag);
    this.meshKeptPass = compileShared(gl, glsl.fullscreenVert, glsl.meshKeptFrag);
    this.edgesPass = compileShared(gl, glsl.fullscreenVert, glsl.edgesFrag);
    this.edgeRowsPass = compileShared(gl, glsl.fullscreenVert, glsl.edgeRowsFrag);
    this.reliabilityPass = compileShared(gl, glsl.fullscreenVert, glsl.reliabilityFrag);
    this.blendTarget = null;   // {width, height, fbo, copyFbo, accumulated, blendedDepth, front, frontCopy}
    this.passFbo = null;       // the reliability passes draw into each camera's images in turn
  }

  deleteCamera(c) {
    const gl = this.gl;
    for (const t of [c.depth, c.rays, c.color, c.edges, c.across, c.reliability, c.kept]) gl.deleteTexture(t);
  }

  makeCamera(cam) {
    const gl = this.gl;
    const texture = (internal, format, type, data, w = cam.width, h = cam.height) => {
      const t = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, t);
      gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
      gl.texImage2D(gl.TEXTURE_2D, 0, internal, w, h, 0, format, type, data);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
      return t;
    };
    return {
      width: cam.width,
      height: cam.height,
      // The footprint's radius per metre of depth (splat_radius_per_metre, point_cloud.hpp).
      radiusPerMetre: 0.75 * 2 / (cam.intrinsics[0] + cam.intrinsics[1]),
      siteFromCamera: cam.siteFromCamera,
      depth: texture(gl.R16UI, gl.RED_INTEGER, gl.UNSIGNED_SHORT,
                     new Uint16Array(cam.width * cam.height)),
      rays: texture(gl.RG32F, gl.RG, gl.FLOAT, cam.rays),
      color: texture(gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, null),
      // Blending's reliability (edges.frag, edge_rows.frag, reliability.frag), per new depth.
      edges: texture(gl.R8UI, gl.RED_INTEGER, gl.UNSIGNED_BYTE, null),
      across: texture(gl.R8UI, gl.RED_INTEGER, gl.UNSIGNED_BYTE, null),
      reliability: texture(gl.RG16F, gl.RG, gl.HALF_FLOAT, null),
      reliabilityRadius: 0,  // the edgePx it was made for; 0: not made for this depth
      // The mesh's kept triangles (mesh_kept.frag), per quad, and what they were made for.
      kept: texture(gl.R8UI, gl.RED_INTEGER, gl.UNSIGNED_BYTE, null, Math.max(cam.width - 1, 1),
                    Math.max(cam.height - 1, 1)),
      keptFor: '',
      gain: [1, 1, 1],       // colour balance (the native renderer's colour_gains)
      hasDepth: false,
      hasColor: false,
    };
  }

  // One camera's decoded depth (Uint16Array) and color (ImageBitmap, closed here; or rgba, a
  // Uint8Array of width x height x 4, alpha 0 where the colour camera did not reach) or nulls.
  uploadCamera(c, f) {
    const gl = this.gl;
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    if (f.depth) {
      c.reliabilityRadius = 0;
      c.keptFor = '';
    }
    if (f.rgba) {
      gl.bindTexture(gl.TEXTURE_2D, c.color);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, c.width, c.height, 0, gl.RGBA, gl.UNSIGNED_BYTE, f.rgba);
      c.hasColor = true;
    }
    if (f.depth) {
      gl.bindTexture(gl.TEXTURE_2D, c.depth);
      gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, c.width, c.height, gl.RED_INTEGER,
                       gl.UNSIGNED_SHORT, f.depth);
      c.hasDepth = true;
    }
    if (f.color) {
      gl.bindTexture(gl.TEXTURE_2D, c.color);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, f.color);
      f.color.close();
      c.hasColor = true;
    } else if (!f.rgba) {
      c.hasColor = false;
    }
  }

  // Makes camera c's reliability image again if its depth or edgePx changed: three passes, each
  // one triangle over the camera's image, as the native renderer's update_reliability.
  updateReliability(c, edgePx) {
    const gl = this.gl;
    if (c.reliabilityRadius === edgePx) return;
    if (!this.passFbo) this.passFbo = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.passFbo);
    gl.viewport(0, 0, c.width, c.height);
    gl.disable(gl.DEPTH_TEST);
    gl.disable(gl.BLEND);
    gl.disable(gl.SCISSOR_TEST);
    gl.colorMask(true, true, true, true);
    const bind = (unit, texture) => {
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, texture);
    };
    const pass = (p, image, uniforms) => {
      gl.useProgram(p.program);
      gl.uniform2i(p.uniforms.size, c.width, c.height);
      uniforms(p.uniforms);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, image, 0);
      gl.drawArrays(gl.TRIANGLES, 0, 3);
    };
    bind(2, null);  // nothing a pass draws into may sit on a unit
    bind(3, null);
    bind(0, c.depth);
    bind(1, c.rays);
    pass(this.edgesPass, c.edges, (u) => gl.uniform1f(u.edge_step, EDGE_STEP));
    bind(0, c.edges);
    pass(this.edgeRowsPass, c.across, (u) => gl.uniform1i(u.radius, edgePx));
    bind(0, c.depth);
    bind(5, c.across);
    pass(this.reliabilityPass, c.reliability, (u) => gl.uniform1i(u.radius, edgePx));
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, null, 0);
    bind(5, null);
    c.reliabilityRadius = edgePx;
  }

  // Makes camera c's kept triangles again if its depth, the avatar filter's keep sphere
  // (`keepSphere`, camera frame) or the edge threshold changed: one pass over its quads.
  updateKept(c, keepSphere, edgeRatio) {
    const gl = this.gl;
    const key = `${keepSphere.join(',')}:${edgeRatio}`;
    if (c.keptFor === key || c.width < 2 || c.height < 2) return;
    if (!this.passFbo) this.passFbo = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.passFbo);
    gl.viewport(0, 0, c.width - 1, c.height - 1);
    gl.disable(gl.DEPTH_TEST);
    gl.disable(gl.BLEND);
    gl.disable(gl.SCISSOR_TEST);
    gl.colorMask(true, true, true, true);
    const p = this.meshKeptPass;
    gl.useProgram(p.program);
    gl.uniform2i(p.uniforms.size, c.width, c.height);
    gl.uniform1f(p.uniforms.max_edge_ratio, edgeRatio);
    gl.uniform4fv(p.uniforms.keep_sphere, keepSphere);
    gl.uniform3f(p.uniforms.hide_half_extent, 0, 0, 0);
    [c.depth, c.rays].forEach((t, unit) => {
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, t);
    });
    gl.activeTexture(gl.TEXTURE6);
    gl.bindTexture(gl.TEXTURE_2D, null);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, c.kept, 0);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, null, 0);
    c.keptFor = key;
  }

  // The blending pass's targets at w x h: accumulated colour (RGBA16F), accumulated view depth
  // (RG32F, or RG16F without EXT_float_blend) and the prepass's depth, with a copy that the
  // weighted pass reads (as the native ensure_blend_target).
  ensureBlendTarget(w, h) {
    const gl = this.gl;
    const t = this.blendTarget;
    if (t && t.width === w && t.height === h) return t;
    if (t) {
      for (const x of [t.accumulated, t.blendedDepth, t.front, t.frontCopy]) gl.deleteTexture(x);
      gl.deleteFramebuffer(t.fbo);
      gl.deleteFramebuffer(t.copyFbo);
    }
    const texture = (internal) => {
      const x = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, x);
      gl.texStorage2D(gl.TEXTURE_2D, 1, internal, w, h);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
      return x;
    };
    const n = {width: w, height: h, accumulated: texture(gl.RGBA16F),
               blendedDepth: texture(this.floatBlend ? gl.RG32F : gl.RG16F),
               front: texture(gl.DEPTH_COMPONENT32F), frontCopy: texture(gl.DEPTH_COMPONENT32F),
               fbo: gl.createFramebuffer(), copyFbo: gl.createFramebuffer()};
    gl.bindFramebuffer(gl.FRAMEBUFFER, n.fbo);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, n.accumulated, 0);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT1, gl.TEXTURE_2D, n.blendedDepth, 0);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.TEXTURE_2D, n.front, 0);
    gl.drawBuffers([gl.COLOR_ATTACHMENT0, gl.COLOR_ATTACHMENT1]);
    const status = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
    gl.bindFramebuffer(gl.FRAMEBUFFER, n.copyFbo);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.TEXTURE_2D, n.frontCopy, 0);
    if (status !== gl.FRAMEBUFFER_COMPLETE)
      throw new Error(`camera renderer: blending framebuffer ${w}x${h} is not complete (${status})`);
    this.blendTarget = n;
    return n;
  }

  // Draws each camera of `draws` once with program `s` (in use), as the native draw_each.
  drawEach(s, draws, o, viewFromRoom, depthPush, accumulate, frontCopy) {
    const gl = this.gl, u = s.uniforms;
    gl.uniform1f(u.depth_push, depthPush);
    gl.uniform1i(u.accumulate, accumulate ? 1 : 0);
    gl.activeTexture(gl.TEXTURE4);
    gl.bindTexture(gl.TEXTURE_2D, frontCopy);
    for (const {c, roomFromCamera, keepSphere} of draws) {
      gl.uniformMatrix4fv(u.view_from_camera, false, multiply(viewFromRoom, roomFromCamera));
      gl.uniform4fv(u.keep_sphere, keepSphere);
      gl.uniform3f(u.hide_half_extent, 0, 0, 0);
      gl.uniform2i(u.size, c.width, c.height);
      gl.uniform1i(u.has_color, c.hasColor ? 1 : 0);
      gl.uniform4f(u.tint, 0, 0, 0, 0);
      gl.uniform3fv(u.gain, o.balanceColour === false ? [1, 1, 1] : c.gain);
      [c.depth, c.rays, c.color, c.reliability].forEach((t, unit) => {
        gl.activeTexture(gl.TEXTURE0 + unit);
        gl.bindTexture(gl.TEXTURE_2D, t);
      });
      if (o.surface === 'mesh') {
        gl.activeTexture(gl.TEXTURE6);
        gl.bindTexture(gl.TEXTURE_2D, c.kept);
        gl.drawArrays(gl.TRIANGLES, 0, (c.width - 1) * (c.height - 1) * 6);
      } else {
        gl.uniform1f(u.radius_per_metre, c.radiusPerMetre * o.splatScale);
        gl.drawArrays(gl.POINTS, 0, c.width * c.height);
      }
    }
  }

  // The site's cameras and the camera avatars (`draws`: [{c, roomFromCamera, keep}]) into the
  // bound framebuffer's `viewport`, drawn through clipFromView x viewFromRoom with settings `o`
  // (CAMERA_DEFAULTS): as the native CameraRenderer::draw_cameras -- plain, or blended in three
  // passes (the front depth pushed back; what lies within blendDepthM of it, weighted, summed;
  // the weighted mean into the target). Pick mode draws plain, each fragment writing its depth.
  drawCameras(draws, o, clipFromView, viewFromRoom, viewport, pick) {
    const gl = this.gl;
    if (!draws.length || viewport[2] < 1 || viewport[3] < 1) return;
    const mesh = o.surface === 'mesh';
    const blend = o.blend && !pick && this.floatTargets;
    const reliable = blend && o.weighting === 'reliability';
    const target = gl.getParameter(gl.FRAMEBUFFER_BINDING);
    for (const d of draws) {
      // A camera avatar keeps its sender's points within keep[3] metres of its head (room
      // frame): the avatar filter's keep sphere, in the camera's frame.
      const k = d.keep;
      const centre = k[3] > 0 ? apply(invert(d.roomFromCamera), [k[0], k[1], k[2], 1]) : [0, 0, 0];
      d.keepSphere = [centre[0], centre[1], centre[2], k[3]];
      if (mesh) this.updateKept(d.c, d.keepSphere, o.edgeRatio);
      if (reliable) this.updateReliability(d.c, o.edgePx);
    }
    const s = pick ? (mesh ? this.meshPick : this.splatPick) : (mesh ? this.mesh : this.splat);
    const [x, y, w, h] = viewport;
    const u = s.uniforms;
    gl.useProgram(s.program);
    gl.bindVertexArray(this.empty);
    const viewFromClip = invert(clipFromView);
    gl.uniformMatrix4fv(u.clip_from_view, false, clipFromView);
    gl.uniform1i(u.weighting, reliable ? 1 : 0);
    gl.uniform1f(u.erode_push, o.erodeDepthM);
    gl.uniform1f(u.blend_push, o.blendDepthM);
    gl.uniform2f(u.viewport_size, w, h);
    if (!mesh) {
      gl.uniform1i(u.size_mode, SPLAT_SIZES[o.splatSize] ?? 2);
      gl.uniform1f(u.fixed_px, o.fixedPx);
      gl.uniform1f(u.pixels_per_unit, 0.5 * h * clipFromView[5]);
      gl.uniform1f(u.splat_scale, o.splatScale);
      gl.uniform2f(u.half_viewport, 0.5 * w, 0.5 * h);
    }
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LESS);
    if (!blend) {
      gl.bindFramebuffer(gl.FRAMEBUFFER, target);
      gl.viewport(x, y, w, h);
      this.drawEach(s, draws, o, viewFromRoom, 0, false, null);
      return;
    }
    const t = this.ensureBlendTarget(w, h);
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.fbo);
    gl.viewport(0, 0, w, h);
    gl.disable(gl.SCISSOR_TEST);
    gl.clearColor(0, 0, 0, 0);
    gl.depthMask(true);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.colorMask(false, false, false, false);
    this.drawEach(s, draws, o, viewFromRoom, o.blendDepthM, false, t.frontCopy);
    gl.colorMask(true, true, true, true);
    if (reliable) {  // the weighted pass reads the front depth: a copy, not its own attachment
      gl.bindFramebuffer(gl.READ_FRAMEBUFFER, t.fbo);
      gl.bindFramebuffer(gl.DRAW_FRAMEBUFFER, t.copyFbo);
      gl.blitFramebuffer(0, 0, w, h, 0, 0, w, h, gl.DEPTH_BUFFER_BIT, gl.NEAREST);
      gl.bindFramebuffer(gl.FRAMEBUFFER, t.fbo);
    }
    gl.depthMask(false);
    gl.depthFunc(gl.LEQUAL);
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.ONE, gl.ONE);
    this.drawEach(s, draws, o, viewFromRoom, 0, true, t.frontCopy);
    gl.disable(gl.BLEND);

    gl.bindFramebuffer(gl.FRAMEBUFFER, target);
    gl.viewport(x, y, w, h);
    gl.depthMask(true);
    gl.depthFunc(gl.ALWAYS);
    const r = this.resolve;
    gl.useProgram(r.program);
    gl.uniform2i(r.uniforms.origin, x, y);
    gl.uniform1i(r.uniforms.weighting, reliable ? 1 : 0);
    gl.uniform2f(r.uniforms.viewport_size, w, h);
    gl.uniformMatrix4fv(r.uniforms.view_from_clip, false, viewFromClip);
    gl.uniformMatrix4fv(r.uniforms.clip_from_view, false, clipFromView);
    [t.accumulated, t.front, t.blendedDepth].forEach((tex, unit) => {
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, tex);
    });
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    gl.depthFunc(gl.LESS);
    for (let unit = 0; unit < 5; ++unit) {  // none of the blending targets stays on a unit
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, null);
    }
    gl.activeTexture(gl.TEXTURE0);
  }
}
