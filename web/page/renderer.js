// WebGL2 renderer of the browser viewer: the site's cameras and the others' camera avatars
// (drawn by camera_pass.js with the native CameraRenderer's method and shaders), the room's
// furniture and the other participants as lit boxes (as room_scene.hpp draws them natively);
// pointers and annotations as glowing primitives (drawing.js) and labels' text as quads of canvas
// textures. Renderer.pick reads back where a ray first meets what is drawn: the
// scene drawn again into a small window around the ray's pixel, each fragment writing its depth.
import {CAMERA_DEFAULTS, CameraPass} from './camera_pass.js';
import {compile} from './gl_program.js';
import {apply, invert, multiply, fromPose, scale, translation} from './math.js';

export {CAMERA_DEFAULTS};

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
    this.cameraPass = new CameraPass(gl);  // the cameras' programs, targets and passes
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
    for (const c of this.cameras) this.cameraPass.deleteCamera(c);
    this.cameras = cameras.map((cam) => this.cameraPass.makeCamera(cam));
  }

  // Whether the cameras can be blended (float colour targets: EXT_color_buffer_float).
  get floatTargets() {
    return this.cameraPass.floatTargets;
  }

  // Another participant's camera avatar (worker.js 'avatar-camera'), replacing its last one.
  setAvatarCamera(id, cam) {
    if (this.avatars.has(id)) this.cameraPass.deleteCamera(this.avatars.get(id));
    this.avatars.set(id, this.cameraPass.makeCamera(cam));
  }

  removeAvatar(id) {
    if (!this.avatars.has(id)) return;
    this.cameraPass.deleteCamera(this.avatars.get(id));
    this.avatars.delete(id);
  }

  uploadAvatar(id, frame) {
    const c = this.avatars.get(id);
    if (c) this.cameraPass.uploadCamera(c, frame);
    else if (frame.color) frame.color.close();
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
      if (this.cameras[i]) this.cameraPass.uploadCamera(this.cameras[i], f);
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
    this.cameraPass.drawCameras(draws.filter((d) => d.c.hasDepth), o, clipFromView, viewFromRoom,
                                viewport, !!scene.pick);
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
