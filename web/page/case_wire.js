// The patient case's wire format for the browser (src/session/include/volcast/session/objects.hpp,
// 0x4b Case), parsed in the stream worker: objects of coloured parts (positions metres, object
// frame; normals as 3 snorm8; indices u32), and the CT series for the monitor. Counts are checked
// against the bytes left before anything is allocated, indices against the vertex count, numbers
// for being finite -- as the native parse_case does. Loaded by worker.js (importScripts).
'use strict';

const MAX_CASE_TRIANGLES = 8 << 20;
const MAX_CASE_OBJECTS = 64;
const MAX_OBJECT_PARTS = 256;

function parseCase(payload) {
  const v = new DataView(payload.buffer, payload.byteOffset, payload.byteLength);
  let at = 0;
  const fail = (why) => { throw new Error(`malformed case: ${why}`); };
  const need = (n) => { if (n > payload.length - at) fail('truncated'); };
  const u8 = () => { need(1); return v.getUint8(at++); };
  const u16 = () => { need(2); const x = v.getUint16(at, true); at += 2; return x; };
  const u32 = () => { need(4); const x = v.getUint32(at, true); at += 4; return x; };
  const f32 = () => {
    need(4);
    const x = v.getFloat32(at, true);
    at += 4;
    if (!Number.isFinite(x)) fail('a number is not finite');
    return x;
  };
  const string = () => {
    const n = u16();
    need(n);
    const s = new TextDecoder().decode(payload.subarray(at, at + n));
    at += n;
    return s;
  };
  const pose = () => ({position: [f32(), f32(), f32()], orientation: [f32(), f32(), f32(), f32()]});
  const copy = (Type, count, bytesEach) => {  // aligned copies of little-endian arrays
    need(count * bytesEach);
    const out = new Type(count);
    new Uint8Array(out.buffer).set(payload.subarray(at, at + count * bytesEach));
    at += count * bytesEach;
    return out;
  };
  const c = {generation: u32(), name: string(), objects: [], monitor: null};
  const objects = u16();
  if (objects > MAX_CASE_OBJECTS) fail(`more than ${MAX_CASE_OBJECTS} objects`);
  let triangles = 0;
  for (let o = 0; o < objects; ++o) {
    const object = {name: string(), rest: pose(), parts: [], radius: 0};
    const parts = u16();
    if (parts > MAX_OBJECT_PARTS) fail(`more than ${MAX_OBJECT_PARTS} parts`);
    for (let p = 0; p < parts; ++p) {
      const name = string();
      const rgba = [u8() / 255, u8() / 255, u8() / 255, u8() / 255];
      const vertices = u32(), tris = u32();
      triangles += tris;
      if (triangles > MAX_CASE_TRIANGLES) fail('too many triangles');
      if (vertices * 15 > payload.length - at) fail('vertices: more than the message holds');
      const positions = copy(Float32Array, vertices * 3, 4);
      for (let i = 0; i < positions.length; i += 3) {
        const x = positions[i], y = positions[i + 1], z = positions[i + 2];
        if (!Number.isFinite(x + y + z)) fail('a number is not finite');
        object.radius = Math.max(object.radius, Math.hypot(x, y, z));
      }
      const normals = copy(Int8Array, vertices * 3, 1);
      if (tris * 12 > payload.length - at) fail('triangles: more than the message holds');
      const indices = copy(Uint32Array, tris * 3, 4);
      for (const i of indices) if (i >= vertices) fail('an index is out of range');
      object.parts.push({name, rgba, positions, normals, indices});
    }
    c.objects.push(object);
  }
  if (u8() === 1) {
    const m = {width: u16(), height: u16(), slices: u16(), spacing: [f32(), f32(), f32()],
               hu: null, overlay: null, label: ''};
    if (!m.width || !m.height || !m.slices) fail('an empty monitor series');
    const pixels = m.width * m.height * m.slices;
    m.hu = copy(Int16Array, pixels, 2);
    if (u8() === 1) {
      m.label = string();
      const bits = copy(Uint8Array, (pixels + 7) >> 3, 1);
      m.overlay = new Uint8Array(pixels);
      for (let i = 0; i < pixels; ++i) m.overlay[i] = (bits[i >> 3] >> (i & 7)) & 1;
    }
    c.monitor = m;
  }
  if (at !== payload.length) fail('trailing bytes');
  return c;
}

// The ArrayBuffers of a parsed case, to transfer it to the page without copying.
function caseBuffers(c) {
  const out = [];
  for (const o of c.objects)
    for (const p of o.parts) out.push(p.positions.buffer, p.normals.buffer, p.indices.buffer);
  if (c.monitor) {
    out.push(c.monitor.hu.buffer);
    if (c.monitor.overlay) out.push(c.monitor.overlay.buffer);
  }
  return out;
}
