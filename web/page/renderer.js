// WebGL2 renderer of the browser viewer: the site's cameras and the others' camera avatars
// drawn with the native CameraRenderer's method and shaders (src/render/camera_renderer.hpp;
// one GLSL source, src/render/glsl, generated into camera_glsl.js): a grid mesh (the default) or
// splats, each depth pixel unprojected through the camera's ray table, overlapping cameras
// blended by reliability (depth-edge distance, angle, distance; erosion, a soft depth
// tolerance) through a prepass, a weighted pass into float targets and a resolve; and the room's furniture and the other participants as lit boxes (as room_scene.hpp draws them
// natively); pointers and annotations as glowing primitives (drawing.js) and labels' text as
// quads of canvas textures. Renderer.pick reads back where a ray first meets what is drawn: the
// scene drawn again into a small window around the ray's pixel, each fragment writing its depth.
import * as glsl from './camera_glsl.js';
import {apply, invert, multiply, fromPose, scale, translation} from './math.js';

// Every fragment shader's pick mode: the fragment's window depth, 24 bits in rgb.
const PICK_FS = `
uniform bool pick;
vec4 or_depth(vec4 c) {
  if (!pick) return c;
  highp uint d = uint(clamp(gl_FragCoord.z, 0.0, 1.0) * 16777215.0);
  return vec4(float(d >> 16u), float((d >> 8u) & 255u), float(d & 255u), 255.0) / 255.0;
}
`;
const PICK_WINDOW = 49;  // pixels: a splat (at most 48 across) covering the centre is drawn

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
const IDENTITY = new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);

const BOX_VS = `#version 300 es
precision highp float;
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
uniform mat4 clip_from_model;
uniform mat4 room_from_model;
out vec3 n_room;
out vec3 p_room;
void main() {
  gl_Position = clip_from_model * vec4(position, 1.0);
  n_room = mat3(room_from_model) * normal;
  p_room = (room_from_model * vec4(position, 1.0)).xyz;
}`;

const BOX_FS = `#version 300 es
precision mediump float;
uniform vec4 base;
uniform float emissive;
uniform vec3 lamp;
uniform bool grid;
in vec3 n_room;
in vec3 p_room;
out vec4 out_color;
` + PICK_FS + `
void main() {
  vec3 n = normalize(n_room);
  vec3 l = normalize(lamp - p_room);
  float light = 0.45 + 0.55 * max(dot(n, l), 0.0);
  vec3 c = mix(base.rgb * light, base.rgb, emissive);
  if (grid) {
    vec2 f = abs(fract(p_room.xz) - 0.5);
    if (max(f.x, f.y) > 0.49) c *= 0.8;
  }
  out_color = or_depth(vec4(c, base.a));
}`;

const QUAD_VS = `#version 300 es
uniform mat4 clip_from_quad;
out vec2 uv;
void main() {
  vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));
  uv = vec2(corner.x, 1.0 - corner.y);  // image row 0 at the top
  gl_Position = clip_from_quad * vec4(corner - 0.5, 0.0, 1.0);
}`;

const QUAD_FS = `#version 300 es
precision mediump float;
uniform sampler2D image;
in vec2 uv;
out vec4 out_color;
` + PICK_FS + `
void main() { out_color = or_depth(vec4(texture(image, uv).rgb, 1.0)); }`;

// DICOM's linear VOI function (PS3.3 C.11.2.1.2.1) to 0..255, as session::window_gray.
export function windowGray(hu, center, width) {
  const w = Math.max(1, width);
  if (hu <= center - 0.5 - (w - 1) / 2) return 0;
  if (hu > center - 0.5 + (w - 1) / 2 || w <= 1) return 255;
  return Math.round(((hu - (center - 0.5)) / (w - 1) + 0.5) * 255);
}

// The monitor's picture of `state.slice` (RGBA, row 0 at the top), as session::monitor_image.
export function monitorImage(series, state) {
  const n = series.width * series.height, base = state.slice * n;
  const out = new Uint8Array(n * 4);
  for (let i = 0; i < n; ++i) {
    const g = windowGray(series.hu[base + i], state.center, state.width);
    const o = i * 4;
    if (state.overlay && series.overlay && series.overlay[base + i]) {
      out[o] = Math.floor((g * 3 + 255 * 2) / 5);
      out[o + 1] = Math.floor((g * 3 + 140 * 2) / 5);
      out[o + 2] = Math.floor((g * 3 + 25 * 2) / 5);
    } else {
      out[o] = out[o + 1] = out[o + 2] = g;
    }
    out[o + 3] = 255;
  }
  return out;
}

function compile(gl, vs, fs) {
  const program = gl.createProgram();
  for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS))
      throw new Error('shader: ' + gl.getShaderInfoLog(s));
    gl.attachShader(program, s);
  }
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS))
    throw new Error('program: ' + gl.getProgramInfoLog(program));
  const uniforms = {};
  const n = gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS);
  for (let i = 0; i < n; ++i) {
    const name = gl.getActiveUniform(program, i).name;
    uniforms[name] = gl.getUniformLocation(program, name);
  }
  return {program, uniforms};
}

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

// A unit cube (-1..1) with face normals: 36 vertices of position + normal.
function cube() {
  const faces = [
    [[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[-1, 0, 0], [0, 0, 1], [0, 1, 0]],
    [[0, 1, 0], [0, 0, 1], [1, 0, 0]], [[0, -1, 0], [1, 0, 0], [0, 0, 1]],
    [[0, 0, 1], [1, 0, 0], [0, 1, 0]], [[0, 0, -1], [0, 1, 0], [1, 0, 0]],
  ];
  const out = [];
  for (const [n, u, v] of faces) {
    const corner = (a, b) => n.map((x, i) => x + a * u[i] + b * v[i]);
    for (const [a, b] of [[-1, -1], [1, -1], [1, 1], [-1, -1], [1, 1], [-1, 1]])
      out.push(...corner(a, b), ...n);
  }
  return new Float32Array(out);
}

// A cylinder (radius 0.5 about +y, -0.5..0.5) and a sphere (diameter 1): position + normal.
function cylinder(sides = 16) {
  const out = [];
  for (let i = 0; i < sides; ++i) {
    const a = (2 * Math.PI * i) / sides, b = (2 * Math.PI * (i + 1)) / sides;
    const p = (t, y) => [0.5 * Math.cos(t), y, 0.5 * Math.sin(t)];
    const n = (t) => [Math.cos(t), 0, Math.sin(t)];
    for (const [t, y] of [[a, -0.5], [b, 0.5], [b, -0.5], [a, -0.5], [a, 0.5], [b, 0.5]])
      out.push(...p(t, y), ...n(t));
    for (const y of [-0.5, 0.5])
      for (const t of [0, a, b]) out.push(...(t === 0 ? [0, y, 0] : p(t, y)), 0, Math.sign(y), 0);
  }
  return new Float32Array(out);
}

function sphere(rings = 8, sectors = 12) {
  const out = [];
  const at = (i, j) => {
    const t = (Math.PI * i) / rings, f = (2 * Math.PI * j) / sectors;
    const n = [Math.sin(t) * Math.cos(f), Math.cos(t), Math.sin(t) * Math.sin(f)];
    return [...n.map((x) => 0.5 * x), ...n];
  };
  for (let i = 0; i < rings; ++i)
    for (let j = 0; j < sectors; ++j)
      for (const [a, b] of [[0, 0], [1, 1], [1, 0], [0, 0], [0, 1], [1, 1]]) out.push(...at(i + a, j + b));
  return new Float32Array(out);
}

function shapeVao(gl, data) {
  const vao = gl.createVertexArray();
  gl.bindVertexArray(vao);
  const buffer = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
  gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
  gl.enableVertexAttribArray(0);
  gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 24, 0);
  gl.enableVertexAttribArray(1);
  gl.vertexAttribPointer(1, 3, gl.FLOAT, false, 24, 12);
  gl.bindVertexArray(null);
  return {vao, count: data.length / 6};
}

export class Renderer {
  constructor(gl) {
    this.gl = gl;
    // Blending needs float colour targets (EXT_color_buffer_float: the Quest browser and desktop
    // Chromium have it); the blended depth's sums are RG32F with EXT_float_blend, else RG16F.
    this.floatTargets = !!gl.getExtension('EXT_color_buffer_float');
    this.floatBlend = !!gl.getExtension('EXT_float_blend');
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
    this.box = compile(gl, BOX_VS, BOX_FS);
    this.quad = compile(gl, QUAD_VS, QUAD_FS);
    this.caseParts = [];  // by object: [{vao, buffers, count, rgba}]
    this.monitorTexture = null;
    this.monitorKey = '';
    this.cameras = [];
    this.avatars = new Map();  // participant id -> its camera avatar
    this.empty = gl.createVertexArray();
    this.cubeVao = shapeVao(gl, cube()).vao;
    this.shapes = {box: shapeVao(gl, cube()), cylinder: shapeVao(gl, cylinder()), sphere: shapeVao(gl, sphere())};
    this.labels = new Map();  // text and colour -> {texture, aspect}
    this.picker = null;       // the pick window's framebuffer
    this.sequence = 0;        // the site frame set whose depth is drawn
  }

  // Pick mode on or off in every program (each fragment writes its depth instead of its colour).
  setPick(on) {
    for (const p of [this.box, this.quad]) {  // the cameras' pick programs are their own
      this.gl.useProgram(p.program);
      this.gl.uniform1i(p.uniforms.pick, on ? 1 : 0);
    }
  }

  // Where the ray through pixel (px, py) (from the top left) of a w x h view drawn through
  // `clipFromRoom` first meets what `scene` draws (the site's clouds too where scene.hideSite:
  // AR), pointers and annotations aside: [x, y, z] in the room frame, or null where nothing is.
  pick(clipFromRoom, w, h, px, py, scene) {
    const gl = this.gl, k = PICK_WINDOW;
    if (!this.picker) {
      const fb = gl.createFramebuffer();
      gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
      for (const [format, attachment] of [[gl.RGBA8, gl.COLOR_ATTACHMENT0],
                                          [gl.DEPTH_COMPONENT24, gl.DEPTH_ATTACHMENT]]) {
        const rb = gl.createRenderbuffer();
        gl.bindRenderbuffer(gl.RENDERBUFFER, rb);
        gl.renderbufferStorage(gl.RENDERBUFFER, format, k, k);
        gl.framebufferRenderbuffer(gl.FRAMEBUFFER, attachment, gl.RENDERBUFFER, rb);
      }
      this.picker = fb;
    }
    // The window of k x k pixels centred on the pixel, scaled up to fill the clip volume.
    const cx = (2 * px) / w - 1, cy = 1 - (2 * py) / h, sx = w / k, sy = h / k;
    const window_ = new Float32Array([sx, 0, 0, 0, 0, sy, 0, 0, 0, 0, 1, 0, -sx * cx, -sy * cy, 0, 1]);
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.picker);
    gl.clearColor(1, 1, 1, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    this.setPick(true);
    // Splats keep the full view's sizes: pixels_per_unit and half_viewport scale with the window.
    this.draw(multiply(window_, clipFromRoom), [0, 0, k, k],
              {...scene, pick: true, hideSite: false});
    this.setPick(false);
    const rgba = new Uint8Array(4);
    gl.readPixels((k - 1) / 2, (k - 1) / 2, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    const d = (rgba[0] << 16) | (rgba[1] << 8) | rgba[2];
    if (d >= 0xffffff) return null;
    const p = apply(invert(clipFromRoom), [cx, cy, (2 * d) / 0xffffff - 1]);
    return [p[0] / p[3], p[1] / p[3], p[2] / p[3]];
  }

  // Glowing primitives (drawing.js: pointers, annotations): opaque ones, then the translucent.
  drawPrimitives(clipFromRoom, prims, lamp) {
    const gl = this.gl, b = this.box;
    gl.useProgram(b.program);
    gl.uniform3fv(b.uniforms.lamp, lamp || [0, 2.2, 0]);
    gl.uniform1i(b.uniforms.grid, 0);
    for (const blended of [false, true]) {
      if (blended) {
        gl.enable(gl.BLEND);
        gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA);
        gl.depthMask(false);
      }
      for (const p of prims) {
        if ((p.color[3] < 1) !== blended) continue;
        const shape = this.shapes[p.shape];
        gl.uniformMatrix4fv(b.uniforms.clip_from_model, false, multiply(clipFromRoom, p.roomFromShape));
        gl.uniformMatrix4fv(b.uniforms.room_from_model, false, p.roomFromShape);
        gl.uniform4fv(b.uniforms.base, p.color);
        gl.uniform1f(b.uniforms.emissive, p.emissive || 0);
        gl.bindVertexArray(shape.vao);
        gl.drawArrays(gl.TRIANGLES, 0, shape.count);
      }
    }
    gl.depthMask(true);
    gl.disable(gl.BLEND);
    gl.uniform1f(b.uniforms.emissive, 0);
    gl.bindVertexArray(null);
  }

  // A label's text (white on dark, edged in its author's colour `rgb`) as a texture, made once:
  // {texture, aspect (width / height)}.
  label(text, rgb) {
    const key = `${rgb.join(',')}:${text}`;
    let l = this.labels.get(key);
    if (l) return l;
    const canvas = document.createElement('canvas');
    const c2 = canvas.getContext('2d');
    c2.font = '28px system-ui, sans-serif';
    canvas.width = Math.ceil(c2.measureText(text).width) + 24;
    canvas.height = 44;
    c2.fillStyle = `rgb(${rgb.map((x) => Math.round(x * 255)).join(',')})`;
    c2.fillRect(0, 0, canvas.width, canvas.height);
    c2.fillStyle = '#15181d';
    c2.fillRect(3, 3, canvas.width - 6, canvas.height - 6);
    c2.font = '28px system-ui, sans-serif';
    c2.fillStyle = '#f4f6f8';
    c2.textBaseline = 'middle';
    c2.fillText(text, 12, canvas.height / 2 + 1);
    const gl = this.gl, texture = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, texture);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, canvas);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    if (this.labels.size > 256) {
      const [oldKey, old] = this.labels.entries().next().value;
      gl.deleteTexture(old.texture);
      this.labels.delete(oldKey);
    }
    l = {texture, aspect: canvas.width / canvas.height};
    this.labels.set(key, l);
    return l;
  }

  // Labels' text quads (drawing.js labelQuad).
  drawLabels(clipFromRoom, quads) {
    const gl = this.gl;
    gl.useProgram(this.quad.program);
    gl.bindVertexArray(this.empty);
    gl.activeTexture(gl.TEXTURE0);
    gl.uniform1i(this.quad.uniforms.image, 0);
    for (const q of quads) {
      gl.uniformMatrix4fv(this.quad.uniforms.clip_from_quad, false, multiply(clipFromRoom, q.roomFromQuad));
      gl.bindTexture(gl.TEXTURE_2D, this.label(q.text, q.rgb).texture);
      gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
    }
    gl.bindVertexArray(null);
  }

  // `cameras`: the Welcome's (site_from_camera = world_from_camera, ray tables).
  setCameras(cameras) {
    for (const c of this.cameras) this.deleteCamera(c);
    this.cameras = cameras.map((cam) => this.makeCamera(cam));
  }

  // Another participant's camera avatar (worker.js 'avatar-camera'), replacing its last one.
  setAvatarCamera(id, cam) {
    if (this.avatars.has(id)) this.deleteCamera(this.avatars.get(id));
    this.avatars.set(id, this.makeCamera(cam));
  }

  removeAvatar(id) {
    if (!this.avatars.has(id)) return;
    this.deleteCamera(this.avatars.get(id));
    this.avatars.delete(id);
  }

  uploadAvatar(id, frame) {
    const c = this.avatars.get(id);
    if (c) this.uploadCamera(c, frame);
    else if (frame.color) frame.color.close();
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

  // The site cameras' colour gains ([[r, g, b]] by camera: worker.js's colour balance).
  setGains(gains) {
    gains.forEach((g, i) => {
      if (this.cameras[i]) this.cameras[i].gain = g;
    });
  }

  // One decoded frame set of the site (worker.js 'frames').
  upload(frames) {
    if (frames.cameras.some((f) => f.depth)) this.sequence = frames.sequence;
    frames.cameras.forEach((f, i) => {
      if (this.cameras[i]) this.uploadCamera(this.cameras[i], f);
      else if (f.color) f.color.close();
    });
  }

  // The patient case (case_wire.js parseCase): its parts' meshes, replacing the last case's.
  setCase(c) {
    const gl = this.gl;
    for (const parts of this.caseParts)
      for (const p of parts) {
        gl.deleteVertexArray(p.vao);
        p.buffers.forEach((b) => gl.deleteBuffer(b));
      }
    this.caseParts = c.objects.map((o) => o.parts.filter((p) => p.indices.length).map((p) => {
      const vao = gl.createVertexArray();
      gl.bindVertexArray(vao);
      const buffer = (target, data) => {
        const b = gl.createBuffer();
        gl.bindBuffer(target, b);
        gl.bufferData(target, data, gl.STATIC_DRAW);
        return b;
      };
      const positions = buffer(gl.ARRAY_BUFFER, p.positions);
      gl.enableVertexAttribArray(0);
      gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 12, 0);
      const normals = buffer(gl.ARRAY_BUFFER, p.normals);
      gl.enableVertexAttribArray(1);
      gl.vertexAttribPointer(1, 3, gl.BYTE, true, 3, 0);
      const indices = buffer(gl.ELEMENT_ARRAY_BUFFER, p.indices);
      gl.bindVertexArray(null);
      let cx = 0, cy = 0, cz = 0;  // the part's centre, for sorting the transparent ones
      for (let i = 0; i < p.positions.length; i += 3)
        cx += p.positions[i], cy += p.positions[i + 1], cz += p.positions[i + 2];
      const k = 3 / Math.max(3, p.positions.length);
      return {vao, buffers: [positions, normals, indices], count: p.indices.length, rgba: p.rgba,
              centre: [cx * k, cy * k, cz * k]};
    }));
    this.monitorKey = '';
  }

  // The monitor's texture from `series` at `state` (made again only when either changes).
  setMonitor(series, state, generation) {
    const gl = this.gl;
    const key = `${generation}:${state.slice}:${state.center}:${state.width}:${state.overlay}`;
    if (key === this.monitorKey) return;
    this.monitorKey = key;
    if (!this.monitorTexture) this.monitorTexture = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, this.monitorTexture);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, series.width, series.height, 0, gl.RGBA,
                  gl.UNSIGNED_BYTE, monitorImage(series, state));
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  }

  // The case's objects (scene.objects: [{roomFromObject}], by object index) -- opaque parts, then
  // the half-transparent ones far to near, back faces then front faces, blended -- and the
  // monitor's quad (scene.monitorQuad: room_from_quad of the unit quad) when it has a texture.
  drawCase(clipFromRoom, scene) {
    const gl = this.gl;
    const b = this.box;
    gl.useProgram(b.program);
    gl.uniform3fv(b.uniforms.lamp, scene.lamp || [0, 2.2, 0]);
    gl.uniform1i(b.uniforms.grid, 0);
    const eye = scene.eye || [0, 0, 0];
    const opaque = [], blended = [];
    (scene.objects || []).forEach((o, i) => {
      for (const p of this.caseParts[i] || []) {
        const m = o.roomFromObject;
        const c = [0, 1, 2].map((r) => m[r] * p.centre[0] + m[4 + r] * p.centre[1] + m[8 + r] * p.centre[2] + m[12 + r]);
        const item = {p, m, d: Math.hypot(c[0] - eye[0], c[1] - eye[1], c[2] - eye[2])};
        (p.rgba[3] >= 1 || scene.pick ? opaque : blended).push(item);  // pick: every surface
      }
    });
    blended.sort((x, y) => y.d - x.d);
    const drawPart = ({p, m}) => {
      gl.uniformMatrix4fv(b.uniforms.clip_from_model, false, multiply(clipFromRoom, m));
      gl.uniformMatrix4fv(b.uniforms.room_from_model, false, m);
      gl.uniform4fv(b.uniforms.base, p.rgba);
      gl.bindVertexArray(p.vao);
      gl.drawElements(gl.TRIANGLES, p.count, gl.UNSIGNED_INT, 0);
    };
    opaque.forEach(drawPart);
    if (blended.length) {
      gl.enable(gl.BLEND);
      gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA);
      gl.depthMask(false);
      gl.enable(gl.CULL_FACE);
      for (const item of blended)
        for (const face of [gl.FRONT, gl.BACK]) {
          gl.cullFace(face);
          drawPart(item);
        }
      gl.disable(gl.CULL_FACE);
      gl.depthMask(true);
      gl.disable(gl.BLEND);
    }
    if (scene.monitorQuad && this.monitorTexture) {
      gl.useProgram(this.quad.program);
      gl.uniformMatrix4fv(this.quad.uniforms.clip_from_quad, false,
                          multiply(clipFromRoom, scene.monitorQuad));
      gl.activeTexture(gl.TEXTURE0);
      gl.bindTexture(gl.TEXTURE_2D, this.monitorTexture);
      gl.uniform1i(this.quad.uniforms.image, 0);
      gl.bindVertexArray(this.empty);
      gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
    }
    gl.bindVertexArray(null);
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

  // Draws the scene into the bound framebuffer's `viewport` [x, y, w, h] through
  // `clipFromRoom`. `scene`: {roomFromSite, avatars: [{id, roomFromCamera, keep: [x, y, z,
  // radius]}], boxes: [{roomFromBox (unit cube), color, grid}], lamp [x, y, z], viewFromRoom
  // (the eye's; blending needs it: clipFromRoom = clipFromView x viewFromRoom; without it the
  // cameras are drawn plain), the camera pass's settings (CAMERA_DEFAULTS: surface, blend,
  // weighting, splatSize, splatScale, edgeRatio, ...), hideSite (AR: the site's cameras not
  // drawn), primitives and labels (drawing.js: pointers, annotations, labels' text quads), pick
  // (Renderer.pick)}.
  draw(clipFromRoom, viewport, scene) {
    const gl = this.gl;
    gl.viewport(...viewport);
    gl.enable(gl.DEPTH_TEST);
    const o = {...CAMERA_DEFAULTS};
    for (const k of Object.keys(CAMERA_DEFAULTS)) if (scene[k] !== undefined) o[k] = scene[k];
    if (!scene.viewFromRoom) o.blend = false;
    const viewFromRoom = scene.viewFromRoom || IDENTITY;
    const clipFromView = scene.viewFromRoom ? multiply(clipFromRoom, invert(viewFromRoom)) : clipFromRoom;
    const draws = (scene.hideSite ? [] : this.cameras).map((c) => ({c, roomFromCamera: multiply(scene.roomFromSite, c.siteFromCamera),
                                            keep: [0, 0, 0, 0]}));
    for (const a of scene.avatars || []) {
      const c = this.avatars.get(a.id);
      if (c) draws.push({c, roomFromCamera: a.roomFromCamera, keep: a.keep});
    }
    this.drawCameras(draws.filter((d) => d.c.hasDepth), o, clipFromView, viewFromRoom, viewport,
                     !!scene.pick);
    gl.viewport(...viewport);
    gl.enable(gl.DEPTH_TEST);
    const b = this.box;
    gl.useProgram(b.program);
    gl.bindVertexArray(this.cubeVao);
    gl.uniform3fv(b.uniforms.lamp, scene.lamp || [0, 2.2, 0]);
    for (const box of scene.boxes || []) {
      gl.uniformMatrix4fv(b.uniforms.clip_from_model, false, multiply(clipFromRoom, box.roomFromBox));
      gl.uniformMatrix4fv(b.uniforms.room_from_model, false, box.roomFromBox);
      gl.uniform4fv(b.uniforms.base, box.color);
      gl.uniform1i(b.uniforms.grid, box.grid ? 1 : 0);
      gl.drawArrays(gl.TRIANGLES, 0, 36);
    }
    gl.bindVertexArray(null);
    this.drawCase(clipFromRoom, scene);
    if (scene.pick) return;
    if (scene.primitives) this.drawPrimitives(clipFromRoom, scene.primitives, scene.lamp);
    if (scene.labels) this.drawLabels(clipFromRoom, scene.labels);
  }
}

// An axis-aligned box: centre and half sizes (metres), room frame.
export function roomBox(centre, half, color, grid = false) {
  return {roomFromBox: multiply(translation(...centre), scale(...half)), color, grid};
}

// A box fixed to a pose (room_from_frame): offset and half sizes in the frame.
export function poseBox(pose, offset, half, color) {
  const roomFromFrame = fromPose(pose.position, pose.orientation);
  return {roomFromBox: multiply(roomFromFrame, multiply(translation(...offset), scale(...half))),
          color, grid: false};
}
