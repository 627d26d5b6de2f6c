// The page's playout worklet (web/page/voice_worklet.js, volcast-playout) in Node, without a
// browser: frames fed at the times a loaded TCP path delivers them, the output read back quantum
// by quantum. Synthetic frames (frame k holds the constant (k + 1) / 1000): exact behaviour only.
// Run: node web/test/worklet_test.mjs (CTest: WebWorklet.*); exits non-zero naming what failed.
import assert from 'node:assert/strict';
import path from 'node:path';
import {fileURLToPath, pathToFileURL} from 'node:url';

import {runTests} from './run_tests.mjs';

const RATE = 48000;
const FRAME = 960;
const QUANTUM = 128;
const processors = new Map();
globalThis.sampleRate = RATE;
globalThis.currentTime = 0;
globalThis.AudioWorkletProcessor = class {
  constructor() { this.port = {postMessage() {}, onmessage: null}; }
};
globalThis.registerProcessor = (name, cls) => processors.set(name, cls);
const here = path.dirname(fileURLToPath(import.meta.url));
await import(pathToFileURL(path.join(here, '../page/voice_worklet.js')).href);
const Playout = processors.get('volcast-playout');

// Plays frames `sent` ({frame, arriveMs, spurt}) for `seconds`; returns the frame numbers heard
// in order (one entry per sample run of a frame's value), the samples each got, and the counts
// the worklet last posted. `stall` ([fromMs, toMs)): the page's audio thread not run then (its
// quanta not rendered: the context's clock falls behind by that much for good, as Chromium's does
// when the renderer is not scheduled), while frames keep arriving.
function play(sent, seconds, stall = [0, 0]) {
  const node = new Playout();
  let counts = {};
  const worker = {postMessage(m) { counts = m; }, onmessage: null};
  node.port.onmessage({data: worker});
  const queue = [...sent].sort((a, b) => a.arriveMs - b.arriveMs);
  const heard = [];
  const samples = new Map();
  const out = new Float32Array(QUANTUM);
  for (let q = 0; q * QUANTUM < seconds * RATE; ++q) {
    const nowMs = (q * QUANTUM * 1000) / RATE;
    while (queue.length && queue[0].arriveMs <= nowMs) {
      const f = queue.shift();
      worker.onmessage({data: {frame: f.frame, pcm: new Float32Array(FRAME).fill((f.frame + 1) / 1000),
                               spurt: !!f.spurt}});
    }
    if (nowMs >= stall[0] && nowMs < stall[1]) continue;
    node.process([], [[out]]);
    for (const x of out) {
      if (x === 0) continue;
      const frame = Math.round(x * 1000) - 1;
      if (heard[heard.length - 1] !== frame) heard.push(frame);
      samples.set(frame, (samples.get(frame) || 0) + 1);
    }
  }
  node.quanta = 37;  // post the counts once more
  node.process([], [[out]]);
  return {heard, samples, counts};
}

// A talk spurt of frames [first, last], sent every 20 ms from `startMs`, each 10 ms on the way.
function spurt(first, last, startMs) {
  const frames = [];
  for (let k = first; k <= last; ++k)
    frames.push({frame: k, arriveMs: startMs + (k - first) * 20 + 10, spurt: k === first});
  return frames;
}
const range = (a, b) => Array.from({length: b - a + 1}, (_, i) => a + i);

const tests = {
  // TCP holds frames 20-27 behind a retransmission and delivers them 150 ms late in a burst:
  // the worklet resumes where it stopped, every frame plays whole and in order, and the stall
  // is heard as one pause.
  ResumesAStalledStreamAsAPause() {
    const sent = spurt(0, 59, 0);
    for (const f of sent) if (f.frame >= 20 && f.frame <= 27) f.arriveMs = 20 * 28 + 10;
    const {heard, samples, counts} = play(sent, 2);
    assert.deepEqual(heard, range(0, 59), 'every frame, in order');
    for (const k of range(0, 59)) assert.equal(samples.get(k), FRAME, `frame ${k} played whole`);
    assert.equal(counts.resumed, 1, 'one stall resumed');
    assert.equal(counts.late, 0, 'no frame dropped');
    assert.ok(counts.inserted > 0 && counts.inserted <= 160 * 48, `pause ${counts.inserted}`);
  },
  // A stall longer than 1 s (frames 20-79 held up 1.2 s) is not waited for: what came after
  // its time is dropped and the delay grows, so that the stream catches up.
  DropsWhatALongerStallHeldUp() {
    const sent = spurt(0, 149, 0);
    for (const f of sent) if (f.frame >= 20 && f.frame <= 79) f.arriveMs = 20 * 80 + 10;
    const {heard, counts} = play(sent, 4);
    assert.equal(counts.resumed, 0);
    assert.ok(counts.late > 0, 'frames came after their time');
    assert.ok(!heard.includes(20), 'the stalled frame was not played');
    assert.deepEqual(heard.slice(-20), range(130, 149), 'then the stream plays on');
  },
  // The page's own audio thread not run for 1.2 s in the middle of a talk spurt (a loaded
  // machine; the context's clock then stays 1.2 s behind): the 60 frames that arrived meanwhile
  // wait, and every frame plays, whole and in order, the stall heard as a pause. In the silence
  // after the spurt the delay comes back down: the next spurt's silence before it is cut. Before,
  // a frame more than a second ahead of the play position was taken for a sender that jumped: the
  // worklet jumped too, and the 1.2 s waiting were never played (a loaded run of
  // WebBrowser.SpeaksToANativeParticipantAndHearsOne: frames 242-297 of the talker's, the end of
  // 'Side_Right').
  PlaysWhatWaitedThroughItsOwnStall() {
    const first = spurt(0, 149, 0);
    const second = spurt(250, 269, 5000);
    const {heard, samples, counts} = play([...first, ...second], 8, [1000, 2200]);
    assert.deepEqual(heard, [...range(0, 149), ...range(250, 269)], 'every frame, in order');
    for (const k of [...range(0, 149), ...range(250, 269)])
      assert.equal(samples.get(k), FRAME, `frame ${k} played whole`);
    assert.equal(counts.late, 0, 'no frame dropped');
    assert.ok(counts.skipped >= 1.0 * RATE, `the delay came down in the silence: ${counts.skipped}`);
    assert.ok(counts.target <= 3 * FRAME, `the delay aimed at: ${counts.target}`);
  },
  // A sender whose frame clock started again (its numbers back at 0, more than 5 s behind the
  // play position) is played from its new frames on, not dropped as late.
  PlaysASenderThatStartedAgain() {
    const {heard, counts} = play([...spurt(0, 99, 0), ...spurt(0, 29, 6000)], 7);
    assert.deepEqual(heard, [...range(0, 99), ...range(0, 29)]);
    assert.equal(counts.restarts, 1);
    assert.equal(counts.late, 0);
  },
  // A talk spurt's first frame that arrives later than the delay allows (after a silence) moves
  // the play position back into the silence: the spurt plays whole.
  PlaysALateTalkSpurtWhole() {
    const first = spurt(0, 19, 0);
    const second = spurt(50, 69, 1000).map((f) => ({...f, arriveMs: f.arriveMs + 150}));
    const {heard, samples, counts} = play([...first, ...second], 3);
    assert.deepEqual(heard, [...range(0, 19), ...range(50, 69)]);
    for (const k of range(50, 69)) assert.equal(samples.get(k), FRAME, `frame ${k} played whole`);
    assert.equal(counts.late, 0);
  },
};

runTests('WebWorklet', tests);
