// The voice's audio-thread parts (voice.js loads them into its AudioContext, 48 kHz). Each of the
// first two gets a MessagePort to the stream worker (voice_worker.js) as its node's first message,
// so that voice never waits for the page's main thread.
// - volcast-capture: the microphone cut into 20 ms frames (960 samples) for the Opus encoder, each
//   posted to the worker with the context time of its first sample.
// - volcast-playout: one speaker's playout buffer, played by frame number (the sender's time
//   line), so that the silences within a talk spurt keep their length. A talk spurt's first
//   frame plays `target` (60 ms) after it arrives (the silence before it is stretched or cut,
//   unheard, never back onto a frame played). The frame after the last one played, arriving
//   after its time while only silence has played since (TCP held the stream up behind a
//   retransmission), resumes the stream where it stopped, up to 1 s late: the stall is heard
//   as a pause, not as lost words (as Volcast's native buffer, audio/spurt_buffer.cpp). Any
//   other frame that comes after its time is dropped and the delay grows by a frame (up to
//   200 ms); 10 s without a late frame, or more than target + 100 ms waiting, skip a frame of
//   silence (the delay shrinks, down to 40 ms). Frames that wait longer than the delay because
//   this thread was not run for a while (the context's clock stays behind by as long) all play,
//   up to 5 s of them, and the silence after them brings the delay down again; a frame more than
//   5 s behind the play position or 5 s ahead is a sender whose frame clock jumped: it plays
//   `target` from now, what waited dropped. Posts the worker its cursor, counts, and how much of
//   what it received is still to play (`ahead`, samples) every 100 ms. With processorOptions.log
//   (a page that keeps what it plays, for tests), also posts its node, every 100 ms, the played
//   log: for each 128-sample quantum it played audio in, the
//   quantum's first sample (`currentFrame`, the context's) and the cursor there (the sender's
//   sample): the quantum's sample j is the sender's sample cursor + j.
// - volcast-tap: what the page plays (stereo), posted in blocks of up to 0.5 s of consecutive
//   quanta (what it heard, for tests), each with the context's sample it starts at.
const FRAME = 960;
const MIN_TARGET = 2 * FRAME;   // 40 ms
const MAX_TARGET = 10 * FRAME;  // 200 ms
const SLACK = 5 * FRAME;        // 100 ms above the target
const MAX_STALL = 50 * FRAME;   // 1 s: the longest stall a stream resumes after
const MAX_BEHIND = 250 * FRAME; // 5 s behind the play position: the sender's clock restarted
const MAX_AHEAD = 250 * FRAME;  // 5 s ahead: the most this worklet keeps waiting

class Capture extends AudioWorkletProcessor {
  constructor() {
    super();
    this.frame = new Float32Array(FRAME);
    this.filled = 0;
    this.firstTime = 0;
    this.worker = null;
    this.port.onmessage = (e) => { this.worker = e.data; };
  }
  process(inputs) {
    const input = inputs[0][0];
    if (!input || !this.worker) return true;
    for (let i = 0; i < input.length; ++i) {
      if (this.filled === 0) this.firstTime = currentTime + i / sampleRate;
      this.frame[this.filled++] = input[i];
      if (this.filled === FRAME) {
        this.worker.postMessage({samples: this.frame, time: this.firstTime}, [this.frame.buffer]);
        this.frame = new Float32Array(FRAME);
        this.filled = 0;
      }
    }
    return true;
  }
}

class Playout extends AudioWorkletProcessor {
  constructor(options) {
    super();
    this.log = options?.processorOptions?.log ? [] : null;  // [currentFrame, cursor, ...]
    this.frames = new Map();  // frame number -> Float32Array (960), not yet played
    this.cursor = null;       // the sample being played, on the sender's time line (frame * 960)
    this.newest = -1;         // the newest frame number received
    this.played = null;       // the newest frame number played (some of it, at least)
    this.target = 3 * FRAME;
    this.late = 0;            // frames that came after their time (dropped; the delay grew)
    this.skipped = 0;         // samples of silence skipped to bring the delay down
    this.resumed = 0;         // stalls resumed (the frame after the last played came late)
    this.inserted = 0;        // samples of pause: stalls resumed, silence before spurts stretched
    this.restarts = 0;        // senders that jumped (what waited dropped)
    this.calm = 0;            // samples played since the last late frame or shrink
    this.quanta = 0;
    this.worker = null;
    this.port.onmessage = (e) => {
      this.worker = e.data;
      this.worker.onmessage = (f) => this.put(f.data.frame, f.data.pcm, f.data.spurt);
    };
  }
  put(frame, pcm, spurt) {
    const start = frame * FRAME;
    if (this.cursor === null || start < this.cursor - MAX_BEHIND || start > this.cursor + MAX_AHEAD) {
      // The first frame, or a sender that jumped (its frame clock restarted): play it `target`
      // from now, what waited dropped. Not a frame far ahead of the play position alone: this
      // worklet's own thread, not run for a while (a loaded machine; the context's clock stays
      // behind by as long), finds every frame that arrived meanwhile waiting, and plays them.
      if (this.cursor !== null) ++this.restarts;
      this.frames.clear();
      this.cursor = start - this.target;
    } else if (spurt && this.frames.size === 0) {
      // A talk spurt's first frame while nothing waits (the cursor is in silence, so moving it
      // is not heard): play it `target` from now, never back onto a frame played.
      let to = start - this.target;
      if (this.played !== null) to = Math.max(to, (this.played + 1) * FRAME);
      if (to > this.cursor) this.skipped += to - this.cursor;
      else this.inserted += this.cursor - to;
      this.cursor = to;
    } else if (start < this.cursor && this.played !== null && frame === this.played + 1 &&
               this.cursor - start <= MAX_STALL) {
      // The frame after the last one played, late, and only silence played since: the stream
      // stalled. Resume where it stopped (a pause) rather than lose what is held up behind it.
      ++this.resumed;
      this.inserted += this.cursor - start;
      this.cursor = start;
    }
    if (start + FRAME <= this.cursor) {  // its time has passed: wait a frame longer from now on
      ++this.late;
      this.target = Math.min(MAX_TARGET, this.target + FRAME);
      this.cursor -= FRAME;
      this.calm = 0;
      return;
    }
    this.frames.set(frame, pcm);
    this.newest = Math.max(this.newest, frame);
  }
  process(inputs, outputs) {
    const out = outputs[0][0];
    if (this.cursor === null) return true;
    // Silence at the cursor and more than target + 100 ms waiting (a burst after a stall), or 10 s
    // without a late frame: skip a frame of the silence.
    const ahead = (this.newest + 1) * FRAME - this.cursor;
    const silent = !this.frames.has(Math.floor(this.cursor / FRAME));
    if (silent && (ahead > this.target + SLACK || (this.calm > 10 * sampleRate && this.target > MIN_TARGET))) {
      if (ahead <= this.target + SLACK) this.target -= FRAME;
      this.cursor += FRAME;
      this.skipped += FRAME;
      this.calm = 0;
    }
    const from = this.cursor;
    let any = false;
    let i = 0;
    while (i < out.length) {
      const f = Math.floor(this.cursor / FRAME);
      const offset = this.cursor - f * FRAME;
      const n = Math.min(out.length - i, FRAME - offset);
      const pcm = this.frames.get(f);
      if (pcm) {
        out.set(pcm.subarray(offset, offset + n), i);
        any = true;
        if (this.played === null || f > this.played) this.played = f;
      } else {
        out.fill(0, i, i + n);
      }
      i += n;
      this.cursor += n;
      if (offset + n === FRAME) this.frames.delete(f);
    }
    this.calm += out.length;
    if (this.log && any) this.log.push(currentFrame, from);
    if (++this.quanta % 38 === 0) {  // about every 100 ms
      if (this.worker)
        this.worker.postMessage({cursor: this.cursor, target: this.target, late: this.late,
                                 skipped: this.skipped, resumed: this.resumed,
                                 inserted: this.inserted, restarts: this.restarts,
                                 ahead: Math.max(0, (this.newest + 1) * FRAME - this.cursor)});
      if (this.log && this.log.length) {
        this.port.postMessage(this.log);
        this.log = [];
      }
    }
    return true;
  }
}

class Tap extends AudioWorkletProcessor {
  constructor() {
    super();
    this.block = [new Float32Array(sampleRate / 2), new Float32Array(sampleRate / 2)];
    this.filled = 0;
    this.frame = 0;  // the context's sample of the block's first
  }
  // Posts the block kept so far.
  flush() {
    const out = this.block.map((b) => b.slice(0, this.filled));
    this.port.postMessage({frame: this.frame, out}, out.map((b) => b.buffer));
    this.filled = 0;
  }
  process(inputs) {
    // Chromium does not call a processor for every quantum (not while the graph changes, it
    // seems): a block holds consecutive quanta only.
    if (this.filled > 0 && currentFrame !== this.frame + this.filled) this.flush();
    if (this.filled === 0) this.frame = currentFrame;
    const input = inputs[0];
    const n = 128;
    for (let c = 0; c < 2; ++c) {
      const from = input[Math.min(c, input.length - 1)];
      if (from) this.block[c].set(from, this.filled);
      else this.block[c].fill(0, this.filled, this.filled + n);
    }
    this.filled += n;
    if (this.filled + n > this.block[0].length) this.flush();
    return true;
  }
}

registerProcessor('volcast-capture', Capture);
registerProcessor('volcast-playout', Playout);
registerProcessor('volcast-tap', Tap);
