// The page's session state (web/page/session.js) in Node, without a browser or server: messages
// built here as the server sends them (src/session/include/volcast/session/messages.hpp,
// objects.hpp). Synthetic states: exact behaviour only.
// Run: node web/test/session_test.mjs [NAME] (CTest: WebSession.*); exits non-zero naming what
// failed.
import assert from 'node:assert/strict';
import {webcrypto} from 'node:crypto';
import path from 'node:path';
import {fileURLToPath, pathToFileURL} from 'node:url';

import {runTests} from './run_tests.mjs';

if (!globalThis.crypto) globalThis.crypto = webcrypto;  // Node 18 (Debian 12)
const here = path.dirname(fileURLToPath(import.meta.url));
const {Session, MONITOR_WAIT_MS} = await import(pathToFileURL(path.join(here, '../page/session.js')).href);

const ME = 7, OTHER = 9, GENERATION = 1;
const ABDOMEN = [40, 400], LIVER = [90, 150], BONE = [480, 2500];

// A whole session message (protocol.hpp: magic, version 5, channel 2, type, payload length; little
// endian) around `payload`.
function message(type, payload) {
  const out = new Uint8Array(12 + payload.length);
  const v = new DataView(out.buffer);
  v.setUint32(0, 0x54534356, true);
  v.setUint16(4, 5, true);
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
  return message(0x4d, p);
}
// A session error (0x43): the reason as u16 length + UTF-8.
function sessionError(reason) {
  const text = new TextEncoder().encode(reason);
  const p = new Uint8Array(2 + text.length);
  new DataView(p.buffer).setUint16(0, text.length, true);
  p.set(text, 2);
  return message(0x43, p);
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
  // A new case: no monitor state until the server sends one, whatever was on its way.
  ANewCaseForgetsTheChangeOnItsWay() {
    const {s} = joinedPage();
    press(s, (m) => { m.slice = 2; });
    s.setCase({generation: GENERATION + 1, objects: []});
    assert.equal(s.monitor, null);
  },
};

runTests('WebSession', tests);
