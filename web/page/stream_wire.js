// The Volcast protocol's bytes for the browser's stream worker (worker.js loads it with
// importScripts): the message header (src/net/protocol/include/volcast/net/protocol/protocol.hpp,
// version 5: magic "VCST", version u16, channel u8, type u8, payload length u32, little-endian),
// the bounds it allows, building messages, a bounds-checked reader, and the Welcome (0.2) with its
// cameras' calibrations (wire.hpp put_calibration). What a malformed payload gets is an Error
// naming the message and what was wrong, before anything is allocated from its sizes.
'use strict';

const MAGIC = 0x54534356;  // "VCST" little-endian
const VERSION = self.VolcastMessages.VERSION;  // messages.js (importScripts'd first)
const HEADER = 12;
const MAX_WELCOME = 256 << 10;
const MAX_PAYLOAD = 256 << 20;
const MAX_CAMERAS = 64;
const MAX_SIDE = 4096;
const MAX_SITE_PIXELS = 16 << 20;
const MAX_CONTROL = 4096;
const FRAME_BYTES_PER_PIXEL = 8;
const FRAME_CAMERA_OVERHEAD = 64 << 10;

// The 12-byte header of a message on `channel` of `type` with a payload of `length` bytes.
function header(channel, type, length) {
  const h = new DataView(new ArrayBuffer(HEADER));
  h.setUint32(0, MAGIC, true);
  h.setUint16(4, VERSION, true);
  h.setUint8(6, channel);
  h.setUint8(7, type);
  h.setUint32(8, length, true);
  return new Uint8Array(h.buffer);
}

// A whole message: the header, then `payload` (Uint8Array).
function message(channel, type, payload) {
  const out = new Uint8Array(HEADER + payload.length);
  out.set(header(channel, type, payload.length));
  out.set(payload, HEADER);
  return out;
}

// A string as the protocol writes one: length u16, then its UTF-8 bytes; appended to `parts`.
function putString(parts, text) {
  const bytes = new TextEncoder().encode(text);
  const len = new Uint8Array(2);
  new DataView(len.buffer).setUint16(0, bytes.length, true);
  parts.push(len, bytes);
}

// The Uint8Arrays of `parts` one after another.
function concat(parts) {
  const out = new Uint8Array(parts.reduce((n, p) => n + p.length, 0));
  let at = 0;
  for (const p of parts) {
    out.set(p, at);
    at += p.length;
  }
  return out;
}

// A bounds-checked little-endian reader over one payload; throws naming the message.
class Reader {
  constructor(bytes, what) {
    this.b = bytes;
    this.v = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    this.at = 0;
    this.what = what;
  }
  need(n) {
    if (this.at + n > this.b.length) throw new Error(`malformed ${this.what}: truncated`);
  }
  u8() { this.need(1); return this.v.getUint8(this.at++); }
  u16() { this.need(2); const x = this.v.getUint16(this.at, true); this.at += 2; return x; }
  u32() { this.need(4); const x = this.v.getUint32(this.at, true); this.at += 4; return x; }
  i64() {
    this.need(8);
    const x = Number(this.v.getBigInt64(this.at, true));
    this.at += 8;
    return x;
  }
  u64() {
    this.need(8);
    const x = Number(this.v.getBigUint64(this.at, true));
    this.at += 8;
    return x;
  }
  f64() { this.need(8); const x = this.v.getFloat64(this.at, true); this.at += 8; return x; }
  bytes(n) { this.need(n); const x = this.b.subarray(this.at, this.at + n); this.at += n; return x; }
  string() { return new TextDecoder().decode(this.bytes(this.u16())); }
}

// One camera's calibration (wire.hpp put_calibration): size, 15 intrinsics, world_from_camera.
function readCalibration(r, what) {
  const width = r.u16(), height = r.u16();
  if (!width || !height || width > MAX_SIDE || height > MAX_SIDE)
    throw new Error(`malformed ${what}: size ${width}x${height}`);
  const intrinsics = [];
  for (let i = 0; i < 15; ++i) intrinsics.push(r.f64());
  const rotation = [], translation = [];
  for (let i = 0; i < 9; ++i) rotation.push(r.f64());
  for (let i = 0; i < 3; ++i) translation.push(r.f64());
  if (![...intrinsics, ...rotation, ...translation].every(Number.isFinite))
    throw new Error(`malformed ${what}: a number that is not finite`);
  if (!(intrinsics[0] > 0 && intrinsics[1] > 0))
    throw new Error(`malformed ${what}: focal length must be positive`);
  return {width, height, intrinsics, rotation, translation};
}

// Welcome (0.2): camera count u32 (1..MAX_CAMERAS), per camera its calibration and name, the
// server's clock (µs). Returns {cameras, serverUs, frameLimit}: frameLimit is the largest frame
// set payload those cameras allow (protocol::frame_set_payload_limit), checked before reading one.
function parseWelcome(payload) {
  const r = new Reader(payload, 'welcome');
  const n = r.u32();
  if (n === 0 || n > MAX_CAMERAS) throw new Error(`malformed welcome: camera count ${n}`);
  const list = [];
  let pixels = 0;
  for (let c = 0; c < n; ++c) {
    const cam = readCalibration(r, `welcome, camera ${c}`);
    pixels += cam.width * cam.height;
    if (pixels > MAX_SITE_PIXELS) throw new Error('malformed welcome: too many pixels');
    cam.name = r.string();
    list.push(cam);
  }
  const serverUs = r.i64();
  // protocol::frame_set_payload_limit
  const frameLimit = Math.min(MAX_PAYLOAD, 45 + list.reduce(
      (s, k) => s + 16 + FRAME_CAMERA_OVERHEAD + FRAME_BYTES_PER_PIXEL * k.width * k.height, 0));
  return {cameras: list, serverUs, frameLimit};
}
