// The browser participant's side of the session channel (protocol.hpp channel 2; every message,
// field and limit in src/session/include/volcast/session/messages.hpp): the lobby, joining,
// publishing the head and hands, answering pose echoes, teleports, and the others' poses. The
// others' camera avatars (0x49, 0x4a) never come here: worker.js decodes them. The patient case
// (objects.hpp): its objects' owners and poses (0x4c), grab / move / release (0x0a..0x0c), the
// monitor's shared state (0x4d, 0x0d); the case itself (0x4b) is parsed by the worker
// (case_wire.js) and handed over with setCase(). Voice (voice_messages.hpp): this page's
// microphone state (0x0f) goes out from here and the others' (0x4f) come in here; the voice
// packets themselves (0x0e, 0x4e) never pass the main thread (voice_worker.js). Pointing and
// drawing (annotations.hpp): this page's laser pointer (0x10) and annotations (0x11, erased by
// 0x12) go out from here; the others' pointers (0x50) and the session's annotations (0x51, 0x52)
// come in here (room frame, metres).
import './messages.js';

/// The session message types and the protocol's version (messages.js, written from the C++ table
/// at build time).
export const {VERSION, T, MESSAGES} = globalThis.VolcastMessages;
const MAGIC = 0x54534356;
// How long the page shows its own monitor change before the server's state again (Session
// setMonitor): far past a round trip; a change the server refused shows no longer than this.
export const MONITOR_WAIT_MS = 3000;

// Normalised linear interpolation of unit quaternions (x, y, z, w), the shorter way.
function nlerp(a, b, t) {
  const sign = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0 ? -1 : 1;
  const q = a.map((x, i) => x + t * (sign * b[i] - x));
  const n = Math.hypot(...q);
  return q.map((x) => x / n);
}

class Writer {
  constructor() { this.parts = []; }
  u16(x) { const a = new Uint8Array(2); new DataView(a.buffer).setUint16(0, x, true); this.parts.push(a); return this; }
  u8(x) { this.parts.push(new Uint8Array([x])); return this; }
  raw(bytes) { this.parts.push(bytes); return this; }
  u32(x) { const a = new Uint8Array(4); new DataView(a.buffer).setUint32(0, x, true); this.parts.push(a); return this; }
  i64(x) { const a = new Uint8Array(8); new DataView(a.buffer).setBigInt64(0, BigInt(Math.round(x)), true); this.parts.push(a); return this; }
  f32(x) { const a = new Uint8Array(4); new DataView(a.buffer).setFloat32(0, x, true); this.parts.push(a); return this; }
  string(s) {
    const b = new TextEncoder().encode(s);
    const a = new Uint8Array(2);
    new DataView(a.buffer).setUint16(0, b.length, true);
    this.parts.push(a, b);
    return this;
  }
  pose(p) { p.position.forEach((x) => this.f32(x)); p.orientation.forEach((x) => this.f32(x)); return this; }
  spot(s) { return this.f32(s.x).f32(s.z).f32(s.yaw); }
  message(type) {
    const length = this.parts.reduce((n, p) => n + p.length, 0);
    const out = new Uint8Array(12 + length);
    const v = new DataView(out.buffer);
    v.setUint32(0, MAGIC, true);
    v.setUint16(4, VERSION, true);
    v.setUint8(6, 2);
    v.setUint8(7, type);
    v.setUint32(8, length, true);
    let at = 12;
    for (const p of this.parts) {
      out.set(p, at);
      at += p.length;
    }
    return out.buffer;
  }
}

class Reader {
  constructor(buffer) {
    this.v = new DataView(buffer);
    this.b = new Uint8Array(buffer);
    this.at = 12;
  }
  need(n) { if (this.at + n > this.b.length) throw new Error('malformed session message: truncated'); }
  u8() { this.need(1); return this.v.getUint8(this.at++); }
  u16() { this.need(2); const x = this.v.getUint16(this.at, true); this.at += 2; return x; }
  u32() { this.need(4); const x = this.v.getUint32(this.at, true); this.at += 4; return x; }
  i64() { this.need(8); const x = Number(this.v.getBigInt64(this.at, true)); this.at += 8; return x; }
  f32() { this.need(4); const x = this.v.getFloat32(this.at, true); this.at += 4; return x; }
  string() { const n = this.u16(); this.need(n); const s = new TextDecoder().decode(this.b.subarray(this.at, this.at + n)); this.at += n; return s; }
  spot() { return {x: this.f32(), z: this.f32(), yaw: this.f32()}; }
  pose() {
    const position = [this.f32(), this.f32(), this.f32()];
    return {position, orientation: [this.f32(), this.f32(), this.f32(), this.f32()]};
  }
  body() {
    const flags = this.u8();
    return {handsTracked: (flags & 1) === 1, head: this.pose(), left: this.pose(), right: this.pose()};
  }
}

// The server's session messages this page takes, by type (messages.js, from the C++ table), each a
// step on the Session (`this`) reading its payload from `r`. The others the worker takes
// (WORKER_TYPES: the others' camera avatars, the case, voice packets).
const RECEIVE = {
  [T.SESSION_LIST](r) {
    const n = r.u16();
    this.sessions = [];
    for (let i = 0; i < n; ++i)
      this.sessions.push({id: r.u32(), name: r.string(), participants: r.u16()});
  },
  [T.JOINED](r) {
    this.joined = {id: r.u32(), sessionId: r.u32(), name: r.string(), spot: r.spot(),
                   roomFromSite: {t: [r.f32(), r.f32(), r.f32()], yaw: r.f32()}};
    this.others.clear();
    this.pointers.clear();
    this.annotations.clear();
    this.error = '';
    this.recording = {recording: false, sinceUs: 0, by: ''};  // the server's follows if one runs
  },
  // An error: perhaps about the monitor change on its way, shown no longer
  [T.SESSION_ERROR](r) {
    this.error = r.string();
    this.monitorSent = null;
  },
  [T.PARTICIPANT_JOINED](r) {
    const p = {id: r.u32(), name: r.string(), role: r.u8(), hasCamera: r.u8() === 1,
               spot: r.spot(), body: null, poses: 0, muted: false};
    this.others.set(p.id, p);
  },
  [T.PARTICIPANT_LEFT](r) {
    const id = r.u32();
    this.others.delete(id);
    this.pointers.delete(id);
  },
  [T.POSE_FROM](r) {
    const id = r.u32();
    const seq = r.u32();
    const time = r.i64();
    const echo = r.u8() === 1;
    const body = r.body();
    const p = this.others.get(id);
    if (p) {
      p.body = body;
      p.time = time;
      ++p.poses;
    }
    if (echo) this.send(new Writer().u32(id).u32(seq).message(T.POSE_ECHO));
  },
  [T.POSE_ECHO_FROM](r) {
    r.u32();
    const seq = r.u32();
    const t = this.sentAt.get(seq);
    if (t !== undefined) {
      this.roundTripsMs.push(performance.now() - t);
      if (this.roundTripsMs.length > 1000) this.roundTripsMs.shift();
    }
  },
  [T.TELEPORTED](r) {
    const id = r.u32();
    const from = r.spot();
    const to = r.spot();
    r.i64();
    if (this.joined && id === this.joined.id) this.joined.spot = to;
    const p = this.others.get(id);
    if (p) p.spot = to;
    this.teleports.push({id, from, to, at: performance.now()});
    if (this.teleports.length > 16) this.teleports.shift();
  },
  [T.RECORDING_STATE](r) {
    this.recording = {recording: r.u8() === 1, sinceUs: r.i64(), by: r.string()};
  },
  [T.OBJECT_STATE](r) {
    const generation = r.u32(), object = r.u16(), owner = r.u32(), sequence = r.u32();
    const time = r.i64(), pose = r.pose();
    const o = this.objects[object];
    if (generation !== this.generation || !o || sequence < o.sequence) return;
    const mine = this.joined && owner === this.joined.id;
    if (!(mine && o.owner === owner)) o.pose = pose;  // our own hold: keep our pose
    o.owner = owner;
    o.sequence = sequence;
    o.poses.push([time, pose]);
    if (o.poses.length > 32) o.poses.shift();
  },
  [T.MONITOR_STATE](r) {
    const generation = r.u32();
    const m = {slice: r.u16(), center: r.f32(), width: r.f32(), overlay: r.u8() === 1, by: r.u32()};
    if (generation !== this.generation) return;
    this.monitorServer = m;
    const sent = this.monitorSent;
    if (sent && sent.m.slice === m.slice && sent.m.center === m.center &&
        sent.m.width === m.width && sent.m.overlay === m.overlay)
      this.monitorSent = null;  // what this page set arrived (or the same, from another)
  },
  [T.POINTER_FROM](r) {
    const id = r.u32();
    r.u32();
    const time = r.i64(), on = r.u8() === 1;
    const origin = [r.f32(), r.f32(), r.f32()], hasHit = r.u8() === 1;
    const hit = [r.f32(), r.f32(), r.f32()];
    if (on) this.pointers.set(id, {origin, hasHit, hit, time});
    else this.pointers.delete(id);
  },
  [T.ANNOTATION](r) {
    const a = {id: r.u32(), author: r.u32(), time: r.i64(), tag: r.u32(), kind: r.u8(),
               anchor: r.u8(), generation: r.u32(), slice: r.u16(), points: []};
    const n = r.u16();
    for (let i = 0; i < n; ++i) a.points.push([r.f32(), r.f32(), r.f32()]);
    a.text = r.string();
    this.annotations.set(a.id, a);
  },
  [T.ERASED](r) {
    this.annotations.delete(r.u32());
  },
  [T.VOICE_STATE_FROM](r) {
    const id = r.u32();
    const muted = r.u8() === 1;
    const p = this.others.get(id);
    if (p) p.muted = muted;
  },
};
export const WORKER_TYPES = Object.freeze([T.AVATAR_CAMERA_FROM, T.AVATAR_FRAME_FROM, T.CASE,
                                           T.VOICE_FROM]);
/// The server's types this page's main thread takes (RECEIVE's), for checks against messages.js.
export const SESSION_TYPES = Object.freeze(Object.keys(RECEIVE).map(Number));

// One participant in one session. `send(ArrayBuffer)` writes a whole message; `nowServerUs()`
// is the server's clock as this page estimates it.
export class Session {
  constructor(send, nowServerUs) {
    this.send = send;
    this.nowServerUs = nowServerUs;
    this.joined = null;   // {id, sessionId, name, spot, roomFromSite: {t, yaw}}
    this.others = new Map();  // id -> {id, name, role, hasCamera, spot, body, poses}
    this.sessions = [];
    this.error = '';
    // Whether the room is being recorded (0x53): {recording, sinceUs (server clock), by}.
    this.recording = {recording: false, sinceUs: 0, by: ''};
    this.sequence = 0;
    this.sentAt = new Map();  // pose sequence -> send time (ms), for echoed round trips
    this.roundTripsMs = [];
    this.posesSent = 0;
    this.teleports = [];
    this.generation = 0;     // the case's (0: none)
    this.objects = [];       // by object index: {owner, sequence, pose, poses: [[timeUs, pose]]}
    this.monitorServer = null;  // {slice, center, width, overlay, by}: the server's newest
    this.monitorSent = null;    // {m, atMs}: what this page set, until the server's matches it
    this.pointers = new Map();     // owner id -> {origin, hasHit, hit, time} while held
    this.annotations = new Map();  // id -> {id, author, time, tag, kind, anchor, generation, slice, points, text}
    this.pointerSequence = 0;
    this.annotationTag = 0;
    this.onchange = () => {};
    // Drawn once, sent with every Join: after a cut the server gives this page its own place back
    // (messages.hpp Join's rejoin key); never all zero.
    this.rejoinKey = crypto.getRandomValues(new Uint8Array(16));
    this.rejoinKey[0] |= 1;
    this.lastJoin = null;  // [session, name] of the last join()
  }

  // The case arrived (worker 'case'): every object at rest, held by nobody, no monitor state yet.
  setCase(c) {
    this.generation = c.generation;
    this.objects = c.objects.map((o) => ({owner: 0, sequence: 0, pose: o.rest, poses: []}));
    this.monitor = null;
  }
  grab(object) { this.send(new Writer().u32(this.generation).u16(object).message(T.GRAB)); }
  move(object, pose) {
    const o = this.objects[object];
    if (o && this.joined && o.owner === this.joined.id) o.pose = pose;  // shown at once
    this.send(new Writer().u32(this.generation).u16(object).pose(pose).message(T.OBJECT_MOVE));
  }
  release(object, pose) {
    const o = this.objects[object];
    if (o) o.pose = pose;
    this.send(new Writer().u32(this.generation).u16(object).pose(pose).message(T.RELEASE));
  }
  // Sets the monitor's whole state (0x0d). Until the server's state matches it (or an error came,
  // or MONITOR_WAIT_MS passed: another participant's came after it), `monitor` is this one,
  // so that keys pressed faster than the round trip build on each other instead of on the
  // server's older state: ] then 2 is the next slice in the liver window, not the liver window on
  // the old slice.
  setMonitor(m) {
    this.send(new Writer().u32(this.generation).u16(m.slice).f32(m.center).f32(m.width)
        .u8(m.overlay ? 1 : 0).message(T.SET_MONITOR));
    const by = this.joined ? this.joined.id : 0;
    this.monitorSent = {m: {slice: m.slice, center: Math.fround(m.center),
                            width: Math.fround(m.width), overlay: !!m.overlay, by},
                        atMs: performance.now()};
  }
  // The monitor's state as this page shows it: its own change on the way, else the server's.
  get monitor() {
    const sent = this.monitorSent;
    if (sent && performance.now() - sent.atMs < MONITOR_WAIT_MS) return sent.m;
    return this.monitorServer;
  }
  set monitor(m) {
    this.monitorServer = m;
    this.monitorSent = null;
  }
  // Object `i`'s pose now: held by another, interpolated `delayUs` in the past between the
  // states received (as the native participant shows others' moves); else its newest.
  objectPose(i, delayUs = 40000) {
    const o = this.objects[i];
    if (!o.owner || (this.joined && o.owner === this.joined.id) || o.poses.length < 2) return o.pose;
    const at = this.nowServerUs() - delayUs, q = o.poses;
    if (at <= q[0][0]) return q[0][1];
    for (let k = 1; k < q.length; ++k)
      if (q[k - 1][0] <= at && at < q[k][0]) {
        const t = (at - q[k - 1][0]) / (q[k][0] - q[k - 1][0]);
        const a = q[k - 1][1], b = q[k][1];
        return {position: a.position.map((x, j) => x + t * (b.position[j] - x)),
                orientation: nlerp(a.orientation, b.orientation, t)};
      }
    return o.pose;
  }

  // This page's laser pointer (0x10): shown (`on`) from `origin` (room frame, metres) to `hit`,
  // where it meets a surface when `hasHit` (else it points through `hit`); put away with on false.
  point(on, origin, hasHit, hit) {
    if (!this.joined) return;
    const w = new Writer().u32(++this.pointerSequence).i64(this.nowServerUs()).u8(on ? 1 : 0);
    origin.forEach((x) => w.f32(x));
    w.u8(hasHit ? 1 : 0);
    hit.forEach((x) => w.f32(x));
    this.send(w.message(T.POINTER));
  }
  // Draws an annotation for the session (0x11): {kind: 0 stroke / 1 arrow / 2 label, anchor (0
  // room, 1 monitor), slice (anchor 1), points: [[x, y, z]] room frame, text (a label's)};
  // returns its tag (the server's copy, 0x51, carries it).
  annotate(a) {
    if (!this.joined) return 0;
    const tag = ++this.annotationTag;
    const monitor = a.anchor === 1;
    const w = new Writer().u32(tag).u8(a.kind).u8(a.anchor || 0).u32(monitor ? this.generation : 0)
        .u16(monitor ? a.slice : 0).u16(a.points.length);
    for (const p of a.points) p.forEach((x) => w.f32(x));
    w.string(a.text || '');
    this.send(w.message(T.ANNOTATE));
    return tag;
  }
  erase(id) { this.send(new Writer().u32(id).message(T.ERASE)); }

  voiceState(muted) { if (this.joined) this.send(new Writer().u8(muted ? 1 : 0).message(T.VOICE_STATE)); }

  list() { this.send(new Writer().message(T.LIST_SESSIONS)); }
  join(session, name) {
    this.lastJoin = [session, name];
    this.send(new Writer().string(session).u8(1).string(name).u8(0).u8(0).raw(this.rejoinKey)
        .message(T.JOIN));
  }
  // After the stream reconnected (a new connection): the same session, name and rejoin key.
  rejoin() {
    if (!this.lastJoin) return;
    const session = this.joined ? this.joined.name : this.lastJoin[0];
    this.joined = null;
    this.others.clear();
    this.pointers.clear();
    this.annotations.clear();
    this.join(session, this.lastJoin[1]);
  }
  leave() { this.send(new Writer().message(T.LEAVE)); }
  teleport(spot) { this.send(new Writer().spot(spot).message(T.TELEPORT)); }

  // Publishes the body (room frame: head, hands); every 4th pose asks for echoes.
  publish(body) {
    if (!this.joined) return;
    const seq = ++this.sequence;
    const echo = seq % 4 === 0;
    if (echo) {
      this.sentAt.set(seq, performance.now());
      if (this.sentAt.size > 256) this.sentAt.delete(this.sentAt.keys().next().value);
    }
    const w = new Writer().u32(seq).i64(this.nowServerUs()).u8(echo ? 1 : 0)
        .u8(body.handsTracked ? 1 : 0).pose(body.head).pose(body.left).pose(body.right);
    this.send(w.message(T.POSE));
    ++this.posesSent;
  }

  // One session message from the server (header included).
  receive(buffer) {
    const r = new Reader(buffer);
    const type = r.v.getUint8(7);
    const step = RECEIVE[type];
    if (!step) {
      const m = MESSAGES[type];
      throw new Error(m ? `session message 0x${type.toString(16)} (${m.name}) is not this page's`
                        : `unknown session message 0x${type.toString(16)}`);
    }
    step.call(this, r);
    this.onchange(type);
  }
}
