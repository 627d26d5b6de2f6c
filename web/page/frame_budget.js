// Whether the camera pass blends (renderer.js CAMERA_DEFAULTS.blend), kept by the frame rate.
// Blending costs 2-3x the plain draw (docs/benchmarks.md, `volcast bench --render`), and a
// headset's or a laptop's GPU may not keep its display's rate with it: there a dropped frame is
// worse than a seam. So a page not told blend=0 or blend=1 blends until the median interval of its
// last `windowMs` of frames drawn blended (at least `minFrames` of them) exceeds `over` x the
// display's period; it then draws plain for the rest of the session and says why (reason). It
// does not turn blending back on: intervals cannot tell how much a plain frame leaves to spare
// (the display's vsync rounds them up to its period). An interval over 5 s (a stalled or hidden
// page) and a frame drawn plain (no cameras yet, no float targets) count for nothing.
// The native window and headset decide alike (src/render/include/volcast/render/frame_budget.hpp;
// its tests run these cases with these figures).
export const BUDGET_WINDOW_MS = 2000;
export const BUDGET_MIN_FRAMES = 10;
export const BUDGET_OVER = 1.5;
const LONGEST_COUNTED_MS = 5000;

export class FrameBudget {
  // periodMs: the display's frame period (ms; 1000 / its refresh rate).
  constructor(periodMs,
              {windowMs = BUDGET_WINDOW_MS, minFrames = BUDGET_MIN_FRAMES, over = BUDGET_OVER} = {}) {
    if (!(periodMs > 0)) throw new Error(`frame budget: the period must be positive, not ${periodMs}`);
    this.periodMs = periodMs;
    this.windowMs = windowMs;
    this.minFrames = minFrames;
    this.over = over;
    this.blend = true;
    this.reason = '';
    this.intervals = [];  // the newest frames spanning windowMs (minFrames at least), oldest first
    this.spanMs = 0;      // their sum
  }

  // The display changed (an XR session began or ended): the frames so far are forgotten.
  setPeriod(periodMs) {
    if (!(periodMs > 0) || periodMs === this.periodMs) return;
    this.periodMs = periodMs;
    this.intervals = [];
    this.spanMs = 0;
  }

  // One frame presented intervalMs after the one before it, drawn blended or not. Returns true
  // if this frame turned blending off.
  add(intervalMs, blended) {
    if (!this.blend || !blended || !(intervalMs > 0) || intervalMs > LONGEST_COUNTED_MS) return false;
    this.intervals.push(intervalMs);
    this.spanMs += intervalMs;
    while (this.intervals.length > this.minFrames && this.spanMs - this.intervals[0] >= this.windowMs)
      this.spanMs -= this.intervals.shift();
    if (this.spanMs < this.windowMs || this.intervals.length < this.minFrames) return false;
    // The median (the sorted window's element n >> 1) is over the limit iff at least
    // n - (n >> 1) intervals are: counted, so that a frame allocates nothing.
    const limit = this.over * this.periodMs;
    let over = 0;
    for (const ms of this.intervals) over += ms > limit;
    const n = this.intervals.length;
    if (over < n - (n >> 1)) return false;
    const median = [...this.intervals].sort((a, b) => a - b)[n >> 1];  // once, for the reason
    this.blend = false;
    this.reason = `blending off: frames every ${median.toFixed(1)} ms blended, the display's ` +
                  `period is ${this.periodMs.toFixed(1)} ms (blend=1 keeps it on)`;
    return true;
  }
}
