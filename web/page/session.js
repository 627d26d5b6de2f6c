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
import {decode, encode} from './session_wire.js';

/// The session message types and the protocol's version (messages.js, written from the C++ table
/// at build time).
export const {VERSION, T, MESSAGES} = globalThis.VolcastMessages;
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

// The server's session messages this page takes, by type (messages.js, from the C++ table), each a
// step on the Session (`this`) taking its payload's fields, named as the C++ layout names them
// (session_wire.js decode). The others the worker takes
// (WORKER_TYPES: the others' camera avatars, the case, voice packets).
const RECEIVE = {
  [T.SESSION_LIST](m) {
    this.sessions = m.sessions.map((s) => ({id: s.id, name: s.sessionName,
                                            participants: s.participants}));
  },
  [T.JOINED](m) {
    this.joined = {id: m.participant, sessionId: m.session, name: m.sessionName, spot: m.spot,
                   roomFromSite: {t: m.siteTranslation, yaw: m.siteYaw}};
    this.others.clear();
    this.pointers.clear();
    this.annotations.clear();
    this.error = '';
    this.recording = {recording: false, sinceUs: 0, by: ''};  // the server's follows if one runs
  },
  // An error: perhaps about the monitor change on its way, shown no longer
  [T.SESSION_ERROR](m) {
    this.error = m.reason;
    this.monitorSent = null;
  },
  [T.PARTICIPANT_JOINED](m) {
    this.others.set(m.id, {id: m.id, name: m.displayName, role: m.role, hasCamera: m.hasCamera,
                           spot: m.spot, body: null, poses: 0, muted: false});
  },
  [T.PARTICIPANT_LEFT](m) {
    this.others.delete(m.participant);
    this.pointers.delete(m.participant);
  },
  [T.POSE_FROM](m) {
    const p = this.others.get(m.participant);
    if (p) {
      p.body = {handsTracked: m.handsTracked, head: m.head, left: m.leftHand, right: m.rightHand};
      p.time = m.timeUs;
      ++p.poses;
    }
    if (m.echoWanted)
      this.send(encode(T.POSE_ECHO, {participant: m.participant, sequence: m.sequence}));
  },
  [T.POSE_ECHO_FROM](m) {
    const t = this.sentAt.get(m.sequence);
    if (t !== undefined) {
      this.roundTripsMs.push(performance.now() - t);
      if (this.roundTripsMs.length > 1000) this.roundTripsMs.shift();
    }
  },
  [T.TELEPORTED]({participant: id, from, to}) {
    if (this.joined && id === this.joined.id) this.joined.spot = to;
    const p = this.others.get(id);
    if (p) p.spot = to;
    this.teleports.push({id, from, to, at: performance.now()});
    if (this.teleports.length > 16) this.teleports.shift();
  },
  [T.RECORDING_STATE]({recording, sinceUs, by}) {
    this.recording = {recording, sinceUs, by};
  },
  [T.OBJECT_STATE]({generation, object, owner, sequence, timeUs, pose}) {
    const o = this.objects[object];
    if (generation !== this.generation || !o || sequence < o.sequence) return;
    const mine = this.joined && owner === this.joined.id;
    if (!(mine && o.owner === owner)) o.pose = pose;  // our own hold: keep our pose
    o.owner = owner;
    o.sequence = sequence;
    o.poses.push([timeUs, pose]);
    if (o.poses.length > 32) o.poses.shift();
  },
  [T.MONITOR_STATE]({generation, slice, center, width, overlay, by}) {
    if (generation !== this.generation) return;
    const m = {slice, center, width, overlay, by};
    this.monitorServer = m;
    const sent = this.monitorSent;
    if (sent && sent.m.slice === m.slice && sent.m.center === m.center &&
        sent.m.width === m.width && sent.m.overlay === m.overlay)
      this.monitorSent = null;  // what this page set arrived (or the same, from another)
  },
  [T.POINTER_FROM]({participant: id, timeUs: time, on, origin, hasHit, hit}) {
    if (on) this.pointers.set(id, {origin, hasHit, hit, time});
    else this.pointers.delete(id);
  },
  [T.ANNOTATION](m) {
    this.annotations.set(m.id, {id: m.id, author: m.author, time: m.timeUs, tag: m.tag,
                                kind: m.kind, anchor: m.anchor, generation: m.generation,
                                slice: m.slice, points: m.points, text: m.text});
  },
  [T.ERASED](m) {
    this.annotations.delete(m.id);
  },
  [T.VOICE_STATE_FROM](m) {
    const p = this.others.get(m.participant);
    if (p) p.muted = m.muted;
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
  grab(object) { this.send(encode(T.GRAB, {generation: this.generation, object})); }
  move(object, pose) {
    const o = this.objects[object];
    if (o && this.joined && o.owner === this.joined.id) o.pose = pose;  // shown at once
    this.send(encode(T.OBJECT_MOVE, {generation: this.generation, object, pose}));
  }
  release(object, pose) {
    const o = this.objects[object];
    if (o) o.pose = pose;
    this.send(encode(T.RELEASE, {generation: this.generation, object, pose}));
  }
  // Sets the monitor's whole state (0x0d). Until the server's state matches it (or an error came,
  // or MONITOR_WAIT_MS passed: another participant's came after it), `monitor` is this one,
  // so that keys pressed faster than the round trip build on each other instead of on the
  // server's older state: ] then 2 is the next slice in the liver window, not the liver window on
  // the old slice.
  setMonitor(m) {
    this.send(encode(T.SET_MONITOR, {generation: this.generation, slice: m.slice,
                                     center: m.center, width: m.width, overlay: !!m.overlay}));
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
    this.send(encode(T.POINTER, {sequence: ++this.pointerSequence, timeUs: this.nowServerUs(),
                                 on, origin, hasHit, hit}));
  }
  // Draws an annotation for the session (0x11): {kind: 0 stroke / 1 arrow / 2 label, anchor (0
  // room, 1 monitor), slice (anchor 1), points: [[x, y, z]] room frame, text (a label's)};
  // returns its tag (the server's copy, 0x51, carries it).
  annotate(a) {
    if (!this.joined) return 0;
    const tag = ++this.annotationTag;
    const monitor = a.anchor === 1;
    this.send(encode(T.ANNOTATE, {tag, kind: a.kind, anchor: a.anchor || 0,
                                  generation: monitor ? this.generation : 0,
                                  slice: monitor ? a.slice : 0, points: a.points,
                                  text: a.text || ''}));
    return tag;
  }
  erase(id) { this.send(encode(T.ERASE, {id})); }

  voiceState(muted) { if (this.joined) this.send(encode(T.VOICE_STATE, {muted})); }

  list() { this.send(encode(T.LIST_SESSIONS)); }
  join(session, name) {
    this.lastJoin = [session, name];
    const key = new DataView(this.rejoinKey.buffer);
    this.send(encode(T.JOIN, {sessionName: session, create: true, displayName: name, role: 0,
                              hasCamera: false, rejoinKeyLow: key.getBigUint64(0, true),
                              rejoinKeyHigh: key.getBigUint64(8, true)}));
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
  leave() { this.send(encode(T.LEAVE)); }
  teleport(spot) { this.send(encode(T.TELEPORT, {spot})); }

  // Publishes the body (room frame: head, hands); every 4th pose asks for echoes.
  publish(body) {
    if (!this.joined) return;
    const seq = ++this.sequence;
    const echo = seq % 4 === 0;
    if (echo) {
      this.sentAt.set(seq, performance.now());
      if (this.sentAt.size > 256) this.sentAt.delete(this.sentAt.keys().next().value);
    }
    this.send(encode(T.POSE, {sequence: seq, timeUs: this.nowServerUs(), echoWanted: echo,
                              handsTracked: body.handsTracked, head: body.head,
                              leftHand: body.left, rightHand: body.right}));
    ++this.posesSent;
  }

  // One session message from the server (header included).
  receive(buffer) {
    const type = new DataView(buffer).getUint8(7);
    const step = RECEIVE[type];
    if (!step) {
      const m = MESSAGES[type];
      throw new Error(m ? `session message 0x${type.toString(16)} (${m.name}) is not this page's`
                        : `unknown session message 0x${type.toString(16)}`);
    }
    step.call(this, decode(buffer).m);
    this.onchange(type);
  }
}
