// The page's session state (web/page/session.js) in Node, without a browser or server: messages
// built here as the server sends them (src/session/include/volcast/session/messages.hpp,
// objects.hpp). Synthetic states: exact behaviour only.
// Run: VOLCAST_WEB_DIR=build/dev/share/volcast/web node web/test/session_test.mjs [NAME] (CTest:
// WebSession.*, which sets it): the built page, whose messages.js the build writes from the C++
// message table. Exits non-zero naming what failed.
import assert from 'node:assert/strict';
import {webcrypto} from 'node:crypto';
import path from 'node:path';
import {fileURLToPath, pathToFileURL} from 'node:url';

import {runTests} from './run_tests.mjs';

if (!globalThis.crypto) globalThis.crypto = webcrypto;  // Node 18 (Debian 12)
const here = path.dirname(fileURLToPath(import.meta.url));
const web = process.env.VOLCAST_WEB_DIR;
if (!web) throw new Error('VOLCAST_WEB_DIR: the built page (share/volcast/web) is not named');
const {Session, MONITOR_WAIT_MS, VERSION, T, MESSAGES, SESSION_TYPES, WORKER_TYPES} =
    await import(pathToFileURL(path.join(web, 'session.js')).href);
const {decode, encode} = await import(pathToFileURL(path.join(web, 'session_wire.js')).href);
const {LAYOUTS} = globalThis.VolcastMessages;

const ME = 7, OTHER = 9, GENERATION = 1;
const ABDOMEN = [40, 400], LIVER = [90, 150], BONE = [480, 2500];

// A whole session message (protocol.hpp: magic, version, channel 2, type, payload length; little
// endian) around `payload`.
function message(type, payload) {
  const out = new Uint8Array(12 + payload.length);
  const v = new DataView(out.buffer);
  v.setUint32(0, 0x54534356, true);
  v.setUint16(4, VERSION, true);
  v.setUint8(6, 2);
  v.setUint8(7, type);
  v.setUint32(8, payload.length, true);
  out.set(payload, 12);
  return out.buffer;
}
// The server's monitor state (0x4d): generation, slice, center, width, overlay, by.
function monitorState({slice, center, width, overlay}, by) {
  const p = new Uint8Array(19);
  const v = new DataView(p.buffer);
  v.setUint32(0, GENERATION, true);
  v.setUint16(4, slice, true);
  v.setFloat32(6, center, true);
  v.setFloat32(10, width, true);
  v.setUint8(14, overlay ? 1 : 0);
  v.setUint32(15, by, true);
  return message(T.MONITOR_STATE, p);
}
// A session error (0x43): the reason as u16 length + UTF-8.
function sessionError(reason) {
  const text = new TextEncoder().encode(reason);
  const p = new Uint8Array(2 + text.length);
  new DataView(p.buffer).setUint16(0, text.length, true);
  p.set(text, 2);
  return message(T.SESSION_ERROR, p);
}
// The server's recording state (0x53): recording u8 | since i64 | by (u16 length + UTF-8).
function recordingState(recording, sinceUs, by) {
  const text = new TextEncoder().encode(by);
  const p = new Uint8Array(11 + text.length);
  const v = new DataView(p.buffer);
  v.setUint8(0, recording ? 1 : 0);
  v.setBigInt64(1, BigInt(sinceUs), true);
  v.setUint16(9, text.length, true);
  p.set(text, 11);
  return message(T.RECORDING_STATE, p);
}
// The server's Joined (0x42) for participant `id` in session 'OR' at the room's origin.
function joined(id) {
  const p = new Uint8Array(4 + 4 + 2 + 2 + 12 + 16);
  const v = new DataView(p.buffer);
  v.setUint32(0, id, true);
  v.setUint32(4, 1, true);
  v.setUint16(8, 2, true);
  p.set(new TextEncoder().encode('OR'), 10);
  return message(T.JOINED, p);
}
// A page joined as participant ME, the case's monitor on slice 1 in the abdomen window (as the
// server sets it), and what it sent.
function joinedPage() {
  const sent = [];
  const s = new Session((m) => sent.push(new Uint8Array(m)), () => 0);
  s.joined = {id: ME};
  s.setCase({generation: GENERATION, objects: []});
  s.receive(monitorState({slice: 1, center: ABDOMEN[0], width: ABDOMEN[1], overlay: true}, 0));
  return {s, sent};
}
// What app.js's monitorKey does with a key: the next state from the one shown, set.
function press(s, change) {
  const m = {...s.monitor};
  change(m);
  s.setMonitor(m);
  return m;
}
const view = (m) => [m.slice, m.center, m.width, m.overlay];

const tests = {
  // ] then 2 then o, faster than the round trip: each builds on the one before (not on the
  // server's older state); the server's answers to the first two do not undo the third while it
  // is on its way; once it arrives, the server's state shows, and another's change after it too.
  KeysFasterThanTheRoundTripBuildOnEachOther() {
    const {s, sent} = joinedPage();
    const first = press(s, (m) => { m.slice += 1; });
    const second = press(s, (m) => { [m.center, m.width] = LIVER; });
    const third = press(s, (m) => { m.overlay = !m.overlay; });
    assert.equal(sent.length, 3);
    assert.deepEqual(view(third), [2, LIVER[0], LIVER[1], false]);
    const setSent = new DataView(sent[2].buffer, 12);  // 0x0d: generation, slice, center, width, overlay
    assert.deepEqual([setSent.getUint16(4, true), setSent.getFloat32(6, true),
                      setSent.getFloat32(10, true), setSent.getUint8(14)], [2, 90, 150, 0]);
    s.receive(monitorState(first, ME));
    s.receive(monitorState(second, ME));
    assert.deepEqual(view(s.monitor), view(third), 'the older answers do not undo the newest');
    s.receive(monitorState(third, ME));
    assert.equal(s.monitorSent, null);
    assert.equal(s.monitor.by, ME);
    s.receive(monitorState({slice: 0, center: BONE[0], width: BONE[1], overlay: true}, OTHER));
    assert.deepEqual(view(s.monitor), [0, BONE[0], BONE[1], true]);
    assert.equal(s.monitor.by, OTHER);
  },
  // Another participant's change applied after this page's: the server's answer to this page's
  // never comes as such (the server sends the newest), so the page shows the server's state once
  // MONITOR_WAIT_MS passed.
  AnotherParticipantsLaterChangeShowsAfterTheWait() {
    const {s} = joinedPage();
    press(s, (m) => { m.slice = 2; });
    s.receive(monitorState({slice: 0, center: BONE[0], width: BONE[1], overlay: false}, OTHER));
    assert.equal(s.monitor.slice, 2, 'its own change, on its way');
    s.monitorSent.atMs -= MONITOR_WAIT_MS;
    assert.deepEqual(view(s.monitor), [0, BONE[0], BONE[1], false]);
  },
  // A change the server refused (a session error): the server's state shows again at once.
  ARefusedChangeGivesWayToTheServersState() {
    const {s} = joinedPage();
    press(s, (m) => { m.slice = 3; });
    assert.equal(s.monitor.slice, 3);
    s.receive(sessionError('monitor: slice 3 of 3'));
    assert.equal(s.error, 'monitor: slice 3 of 3');
    assert.deepEqual(view(s.monitor), [1, ABDOMEN[0], ABDOMEN[1], true]);
  },
  // The recording state the server sends shows as it is, until it stops; a new Joined forgets it
  // (the server sends it again after Joined while one runs).
  TheRecordingStateShowsUntilItStopsOrThePageJoinsAgain() {
    const s = new Session(() => {}, () => 0);
    const changes = [];
    s.onchange = (type) => changes.push(type);
    assert.equal(s.recording.recording, false);
    s.receive(recordingState(true, 1_700_000_000_000_000, 'the OR server (volcast serve --record)'));
    assert.deepEqual(s.recording, {recording: true, sinceUs: 1_700_000_000_000_000,
                                   by: 'the OR server (volcast serve --record)'});
    assert.deepEqual(changes, [T.RECORDING_STATE]);
    s.receive(recordingState(false, 0, ''));
    assert.equal(s.recording.recording, false);
    s.receive(recordingState(true, 5, 'Recorder'));
    s.receive(joined(ME));
    assert.equal(s.joined.id, ME);
    assert.deepEqual(s.recording, {recording: false, sinceUs: 0, by: ''});
  },
  // The page takes every type the server sends (messages.js, written from the C++ table), each
  // on one side: the main thread's steps or the worker's; it sends none of them itself.
  EveryServerTypeHasOneStepOnThePage() {
    const down = Object.entries(MESSAGES).filter(([, m]) => !m.up).map(([t]) => Number(t));
    assert.equal(down.length, 19);
    assert.deepEqual([...SESSION_TYPES, ...WORKER_TYPES].sort((a, b) => a - b), down);
    for (const t of [...SESSION_TYPES, ...WORKER_TYPES]) assert.equal(MESSAGES[t].up, false);
    assert.equal(T.MONITOR_STATE, 0x4d);
    assert.equal(MESSAGES[T.CASE].maxPayload, 192 << 20);
    const s = new Session(() => {}, () => 0);
    assert.throws(() => s.receive(message(T.POSE, new Uint8Array(0))), /\(pose\) is not this page's/);
    assert.throws(() => s.receive(message(0x7f, new Uint8Array(0))), /unknown session message 0x7f/);
  },
  // Every layout the build wrote from the C++ ones (messages.js LAYOUTS) writes and reads back
  // the same fields on the page: a value of each kind, f32s that are exact in 32 bits.
  EveryLayoutRoundTripsOnThePage() {
    const SAMPLE = {
      u8: () => 200, u16: () => 60000, u32: () => 4000000000, u64: () => 0x123456789n,
      i64: () => 1_700_000_000_000_000, f32: () => 0.5, finite: () => -1.25,
      string: () => 'héllo', name: () => 'Dr. Müller', flag: () => true, enum: (f) => f.max,
      bytes: () => new Uint8Array([1, 2, 3]),
      spot: () => ({x: 1.5, z: -2, yaw: 0.25}), vec3: () => [0.5, 1, -2],
      pose: () => ({position: [1, 1.5, -2], orientation: [0, 0, 0, 1]}),
      list: (f) => [0, 1].map(() => (f.items.length === 1 ? SAMPLE[f.items[0].kind](f.items[0])
                                                           : sample(f.items))),
    };
    const sample = (fields) => Object.fromEntries(
        fields.filter((f) => f.kind !== 'tail').map((f) => [f.name, SAMPLE[f.kind](f)]));
    const types = Object.keys(LAYOUTS).map(Number);
    assert.equal(types.length, Object.keys(MESSAGES).length - 5, 'all but avatars and the case');
    for (const type of types) {
      const m = sample(LAYOUTS[type]);
      assert.deepEqual(decode(encode(type, m)), {type, m}, MESSAGES[type].name);
    }
    // A Join without its tail (no rejoin key) ends before it, and reads back without it.
    const join = {sessionName: 'OR', create: true, displayName: 'A', role: 0, hasCamera: false};
    assert.equal(encode(T.JOIN, join).byteLength, 12 + 4 + 1 + 3 + 1 + 1);
    assert.deepEqual(decode(encode(T.JOIN, join)).m, join);
  },
  // What the C++ reader refuses, the page refuses in the same words (message_layout_test.cpp).
  TheServersMessagesAreCheckedAsTheCppReaderChecksThem() {
    const spot = {x: 0, z: 0, yaw: 0};
    const joinedOther = {id: OTHER, displayName: 'B', role: 1, hasCamera: false, spot};
    const p = new Uint8Array(encode(T.PARTICIPANT_JOINED, joinedOther));
    const s = new Session(() => {}, () => 0);
    p[12 + 4 + 2 + 1 + 1] = 2;  // has camera
    assert.throws(() => s.receive(p.buffer),
                  /^Error: malformed participant joined: has camera is neither 0 nor 1$/);
    p[12 + 4 + 2 + 1 + 1] = 1;
    p[12 + 4 + 2 + 1] = 2;  // role
    assert.throws(() => s.receive(p.buffer), /unknown role 2/);
    assert.throws(() => s.receive(message(T.ERASED, new Uint8Array(9))),
                  /malformed erased: trailing bytes/);
    assert.throws(() => s.receive(message(T.ERASED, new Uint8Array(7))),
                  /malformed erased: truncated/);
    const nan = new Uint8Array(encode(T.TELEPORTED,
                                      {participant: OTHER, from: spot, to: spot, timeUs: 0}));
    new DataView(nan.buffer).setFloat32(12 + 4 + 12, NaN, true);
    assert.throws(() => s.receive(nan.buffer), /malformed teleported: to is not finite/);
    assert.equal(s.others.size, 0);
  },
  // The page's Join carries its rejoin key as drawn: 16 bytes after the fields, little endian.
  TheJoinCarriesTheRejoinKeyAsDrawn() {
    const sent = [];
    const s = new Session((m) => sent.push(new Uint8Array(m)), () => 0);
    s.join('OR 1', 'Dr. B');
    assert.deepEqual(sent[0].subarray(sent[0].length - 16), s.rejoinKey);
    const {m} = decode(sent[0].buffer);
    assert.deepEqual([m.sessionName, m.displayName, m.create, m.role, m.hasCamera],
                     ['OR 1', 'Dr. B', true, 0, false]);
  },
  // A new case: no monitor state until the server sends one, whatever was on its way.
  ANewCaseForgetsTheChangeOnItsWay() {
    const {s} = joinedPage();
    press(s, (m) => { m.slice = 2; });
    s.setCase({generation: GENERATION + 1, objects: []});
    assert.equal(s.monitor, null);
  },
};

runTests('WebSession', tests);
