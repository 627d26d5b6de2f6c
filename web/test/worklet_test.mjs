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
// the worklet last posted.
function play(sent, seconds) {
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
  // A stall longer than 200 ms is not waited for: what came after its time is dropped and the
  // delay grows, so that the stream catches up.
  DropsWhatALongerStallHeldUp() {
    const sent = spurt(0, 99, 0);
    for (const f of sent) if (f.frame >= 20 && f.frame <= 39) f.arriveMs = 20 * 40 + 10;
    const {heard, counts} = play(sent, 3);
    assert.equal(counts.resumed, 0);
    assert.ok(counts.late > 0, 'frames came after their time');
    assert.ok(!heard.includes(20), 'the stalled frame was not played');
    assert.deepEqual(heard.slice(-20), range(80, 99), 'then the stream plays on');
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
