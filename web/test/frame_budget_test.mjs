// The page's frame budget (web/page/frame_budget.js) in Node, without a browser: frame intervals
// fed as a display presents them. Synthetic intervals: exact behaviour only.
// Run: node web/test/frame_budget_test.mjs [NAME] (CTest: WebFrameBudget.*); exits non-zero naming
// what failed.
import assert from 'node:assert/strict';
import path from 'node:path';
import {fileURLToPath, pathToFileURL} from 'node:url';

import {runTests} from './run_tests.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const {FrameBudget, BUDGET_WINDOW_MS, BUDGET_MIN_FRAMES} = await import(pathToFileURL(path.join(here, '../page/frame_budget.js')).href);
const PERIOD = 1000 / 72;  // a headset's display

// Feeds intervals (ms) drawn blended; returns the index of the frame that turned blending off,
// or -1.
function feed(budget, intervals, blended = true) {
  let off = -1;
  intervals.forEach((ms, i) => {
    if (budget.add(ms, blended)) {
      assert.equal(off, -1, 'blending is turned off once');
      off = i;
    }
  });
  return off;
}
const repeat = (ms, n) => Array(n).fill(ms);

const tests = {
  // Frames at the display's rate, and a little slower (within 1.5 periods), keep blending.
  KeepsBlendingWhileFramesKeepTheDisplaysRate() {
    const b = new FrameBudget(PERIOD);
    assert.equal(feed(b, [...repeat(PERIOD, 500), ...repeat(1.45 * PERIOD, 500)]), -1);
    assert.equal(b.blend, true);
    assert.equal(b.reason, '');
  },
  // Frames every 40 ms (under 25 a second) on a 72 Hz display turn blending off once they span
  // the window (2 s: the 50th), and the reason says the figures.
  TurnsBlendingOffWhenTheMedianFrameIsTooSlow() {
    assert.equal(BUDGET_WINDOW_MS, 2000);
    const b = new FrameBudget(PERIOD);
    assert.equal(feed(b, repeat(40, 200)), 49);
    assert.equal(b.blend, false);
    assert.match(b.reason, /^blending off: frames every 40\.0 ms blended, the display's period is 13\.9 ms/);
    // It stays off, whatever comes after.
    assert.equal(feed(b, repeat(PERIOD, 500)), -1);
    assert.equal(b.blend, false);
  },
  // The median of the window, not its mean: 20 ms frames keep a 13.9 ms period (under 20.8 ms),
  // 25 ms ones do not. 40 slow then 50 fast span 2 s: the median is fast, blending stays; 40 fast
  // then 48 slow span 2 s with the median slow: off at the 88th.
  DecidesOnTheMedian() {
    const b = new FrameBudget(PERIOD);
    assert.equal(feed(b, [...repeat(25, 40), ...repeat(20, 200)]), -1);
    assert.equal(b.blend, true);
    const c = new FrameBudget(PERIOD);
    assert.equal(feed(c, [...repeat(20, 40), ...repeat(25, 200)]), 87);
  },
  // A stalled page (6 s), frames drawn plain (no cameras yet, no float targets) and fewer than
  // 10 frames, however long, count for nothing.
  StallsPlainFramesAndAShortStartCountForNothing() {
    assert.equal(BUDGET_MIN_FRAMES, 10);
    const b = new FrameBudget(PERIOD);
    assert.equal(feed(b, repeat(6000, 30)), -1);
    assert.equal(feed(b, repeat(3 * PERIOD, 300), false), -1);
    assert.equal(feed(b, repeat(300, 9)), -1, '2.7 s in 9 frames');
    assert.equal(b.blend, true);
    assert.equal(feed(b, [300]), 0, 'the 10th frame decides');
  },
  // A new display period (an XR session began) forgets the frames measured against the old one.
  ANewPeriodStartsTheWindowAgain() {
    const b = new FrameBudget(1000 / 60);
    assert.equal(feed(b, repeat(30, 60)), -1, '1.8 s: not yet');
    b.setPeriod(1000 / 20);
    assert.equal(feed(b, repeat(30, 300)), -1, '30 ms frames keep a 50 ms period');
    b.setPeriod(1000 / 60);
    assert.equal(feed(b, repeat(30, 100)), 66, '2 s of 30 ms frames: the 67th');
    assert.throws(() => new FrameBudget(0), /the period must be positive/);
  },
};

runTests('WebFrameBudget', tests);
