// The session channel's messages read and written from their layouts (messages.js LAYOUTS, which
// the build writes from the C++ layouts, src/session/include/volcast/session/message_layout.hpp):
// the page has no layout of its own. A message is the stream's 12-byte header (protocol.hpp:
// magic, version, channel 2, type, payload length; little endian) and its payload, whose fields
// become an object's members by name (camelCase): u8..u32, f32, finite -> Number; u64 -> BigInt;
// i64 -> Number (microseconds fit); string, name -> String; flag -> Boolean; enum -> Number;
// bytes -> Uint8Array (a view of the message); spot -> {x, z, yaw}; pose -> {position: [x, y, z],
// orientation: [x, y, z, w]}; vec3 -> [x, y, z]; list -> Array, each item an object of its fields,
// or the one field's value when an item has one (annotation points: [[x, y, z]]). After a tail
// the fields are absent when the payload ends there, and written only when the first is given.
// The checks are the C++ reader's (same words in the errors): finite numbers, names, flags, enum
// ranges, list counts against their maximum and against the bytes left, no trailing bytes.
import './messages.js';

const {VERSION, MESSAGES, LAYOUTS} = globalThis.VolcastMessages;
const MAGIC = 0x54534356;
const SESSION_CHANNEL = 2;
const HEADER_BYTES = 12;

// 'sessionName' -> 'session name': a field as errors say it (the C++ reader's words).
const spoken = (name) => name.replace(/[A-Z]/g, (c) => ' ' + c.toLowerCase());

class Reader {
  constructor(buffer, what) {
    this.v = new DataView(buffer);
    this.b = new Uint8Array(buffer);
    this.at = HEADER_BYTES;
    this.what = what;
  }
  fail(why) { throw new Error(`malformed ${this.what}: ${why}`); }
  left() { return this.b.length - this.at; }
  need(n) { if (n > this.left()) this.fail('truncated'); }
  take(n, get) { this.need(n); const x = get(this.at); this.at += n; return x; }
  u8() { return this.take(1, (at) => this.v.getUint8(at)); }
  u16() { return this.take(2, (at) => this.v.getUint16(at, true)); }
  u32() { return this.take(4, (at) => this.v.getUint32(at, true)); }
  u64() { return this.take(8, (at) => this.v.getBigUint64(at, true)); }
  i64() { return this.take(8, (at) => Number(this.v.getBigInt64(at, true))); }
  f32() { return this.take(4, (at) => this.v.getFloat32(at, true)); }
  raw(n) { return this.take(n, (at) => this.b.subarray(at, at + n)); }
  string() { return new TextDecoder().decode(this.raw(this.u16())); }
  finite(f) {
    const x = this.f32();
    if (!Number.isFinite(x)) this.fail(`${spoken(f.name)} is not finite`);
    return x;
  }
  finites(f, n) { return Array.from({length: n}, () => this.finite(f)); }
}

const READ = {
  u8: (r) => r.u8(),
  u16: (r) => r.u16(),
  u32: (r) => r.u32(),
  u64: (r) => r.u64(),
  i64: (r) => r.i64(),
  f32: (r) => r.f32(),
  finite: (r, f) => r.finite(f),
  string: (r) => r.string(),
  name(r, f) {
    const bytes = r.raw(r.u16());
    const what = spoken(f.name);
    if (bytes.length < 1 || bytes.length > f.max) r.fail(`${what} must be 1 to ${f.max} bytes`);
    if (bytes.some((c) => c < 0x20 || c === 0x7f)) r.fail(`${what} has a control character`);
    return new TextDecoder().decode(bytes);
  },
  flag(r, f) {
    const b = r.u8();
    if (b > 1) r.fail(`${spoken(f.name)} is neither 0 nor 1`);
    return b === 1;
  },
  enum(r, f) {
    const b = r.u8();
    if (b > f.max) r.fail(`unknown ${spoken(f.name)} ${b}`);
    return b;
  },
  bytes: (r) => r.raw(r.u32()),
  spot(r, f) {
    const [x, z, yaw] = r.finites(f, 3);
    return {x, z, yaw};
  },
  pose: (r, f) => ({position: r.finites(f, 3), orientation: r.finites(f, 4)}),
  vec3: (r, f) => r.finites(f, 3),
  list(r, f) {
    const n = r.u16();
    if (n > f.max) r.fail(`${n} ${spoken(f.name)}, more than ${f.max}`);
    if (n > r.left()) r.fail(`more ${spoken(f.name)} declared than the message holds`);
    return Array.from({length: n}, () => readItem(r, f.items));
  },
};

function readFields(r, fields) {
  const m = {};
  for (const f of fields) {
    if (f.kind === 'tail') {
      if (r.left() === 0) break;
    } else {
      m[f.name] = READ[f.kind](r, f);
    }
  }
  return m;
}
function readItem(r, fields) {
  return fields.length === 1 ? READ[fields[0].kind](r, fields[0]) : readFields(r, fields);
}

/// The type and fields of one whole session message (header included) that has a layout;
/// throws Error("malformed <name>: ...") as the C++ reader does, or naming a type without one.
export function decode(buffer) {
  const v = new DataView(buffer);
  if (buffer.byteLength < HEADER_BYTES || v.getUint32(0, true) !== MAGIC ||
      v.getUint8(6) !== SESSION_CHANNEL)
    throw new Error('malformed session message: not a session channel header');
  const type = v.getUint8(7);
  const layout = LAYOUTS[type];
  if (!layout) throw new Error(`session message 0x${type.toString(16)} has no layout here`);
  const r = new Reader(buffer, MESSAGES[type].name);
  if (v.getUint32(8, true) !== r.left()) r.fail('its length is not the header\'s');
  const m = readFields(r, layout);
  if (r.left() !== 0) r.fail('trailing bytes');
  return {type, m};
}

class Writer {
  constructor() { this.parts = []; this.length = 0; }
  put(n, set) {
    const a = new Uint8Array(n);
    set(new DataView(a.buffer));
    return this.raw(a);
  }
  raw(bytes) { this.parts.push(bytes); this.length += bytes.length; return this; }
  u8(x) { return this.put(1, (v) => v.setUint8(0, x)); }
  u16(x) { return this.put(2, (v) => v.setUint16(0, x, true)); }
  u32(x) { return this.put(4, (v) => v.setUint32(0, x, true)); }
  u64(x) { return this.put(8, (v) => v.setBigUint64(0, BigInt(x), true)); }
  i64(x) { return this.put(8, (v) => v.setBigInt64(0, BigInt(Math.round(x)), true)); }
  f32(x) { return this.put(4, (v) => v.setFloat32(0, x, true)); }
  string(s) { const b = new TextEncoder().encode(s); return this.u16(b.length).raw(b); }
  f32s(xs) { xs.forEach((x) => this.f32(x)); return this; }
}

const WRITE = {
  u8: (w, x) => w.u8(x),
  u16: (w, x) => w.u16(x),
  u32: (w, x) => w.u32(x),
  u64: (w, x) => w.u64(x),
  i64: (w, x) => w.i64(x),
  f32: (w, x) => w.f32(x),
  finite: (w, x) => w.f32(x),
  string: (w, s) => w.string(s),
  name: (w, s) => w.string(s),
  flag: (w, x) => w.u8(x ? 1 : 0),
  enum: (w, x) => w.u8(x),
  bytes: (w, b) => w.u32(b.length).raw(b),
  spot: (w, s) => w.f32s([s.x, s.z, s.yaw]),
  pose: (w, p) => w.f32s(p.position).f32s(p.orientation),
  vec3: (w, v) => w.f32s(v),
  list(w, items, f) {
    if (items.length > f.max) throw new Error(`${spoken(f.name)}: more than ${f.max}`);
    w.u16(items.length);
    for (const item of items) {
      if (f.items.length === 1) WRITE[f.items[0].kind](w, item, f.items[0]);
      else writeFields(w, f.items, item);
    }
  },
};

function writeFields(w, fields, m, what) {
  for (let i = 0; i < fields.length; ++i) {
    const f = fields[i];
    if (f.kind === 'tail') {
      if (m[fields[i + 1].name] === undefined) return;
    } else {
      if (m[f.name] === undefined) throw new Error(`${what}: ${f.name} is missing`);
      WRITE[f.kind](w, m[f.name], f);
    }
  }
}

/// A whole session message of `type` (header included) with the fields of `m` (by name, as
/// decode returns them), as an ArrayBuffer; throws Error naming a missing field.
export function encode(type, m = {}) {
  const w = new Writer();
  writeFields(w, LAYOUTS[type], m, MESSAGES[type].name);
  const out = new Uint8Array(HEADER_BYTES + w.length);
  const v = new DataView(out.buffer);
  v.setUint32(0, MAGIC, true);
  v.setUint16(4, VERSION, true);
  v.setUint8(6, SESSION_CHANNEL);
  v.setUint8(7, type);
  v.setUint32(8, w.length, true);
  let at = HEADER_BYTES;
  for (const p of w.parts) {
    out.set(p, at);
    at += p.length;
  }
  return out.buffer;
}
