// The browser participant's voice, its main-thread side (issue 35; docs/voice.md): the audio
// context and its graph. The microphone comes through getUserMedia (with the browser's echo
// cancellation, noise suppression and gain control) into the capture worklet
// (voice_worklet.js), which posts 20 ms frames straight to the stream worker; the worker
// (voice_worker.js) encodes, sends, receives and decodes, and posts each speaker's frames
// straight to that speaker's playout worklet. Here: each speaker's playout -> GainNode (its
// volume) -> PannerNode (HRTF, inverse-distance attenuation) at the speaker's head (room frame,
// metres; the OR site, participant 1, above the table) -> the loudspeaker, and the listener at
// this page's head. The page's main thread may stall (a slow GPU) without delaying a voice.
const RATE = 48000;
const SITE_ID = 1;                   // the OR site's microphone (messages.hpp)
const SITE_POSITION = [0, 1.5, 0];   // above the table, as VoiceConfig::site_position

// Channels of equal length (float, [-1, 1]) as a 16-bit PCM WAV file at RATE, base64.
function wavBase64(channels) {
  const n = channels[0].length, c = channels.length;
  const bytes = new Uint8Array(44 + n * 2 * c);
  const v = new DataView(bytes.buffer);
  const text = (at, s) => [...s].forEach((ch, i) => v.setUint8(at + i, ch.charCodeAt(0)));
  text(0, 'RIFF');
  v.setUint32(4, 36 + n * 2 * c, true);
  text(8, 'WAVEfmt ');
  v.setUint32(16, 16, true);
  v.setUint16(20, 1, true);  // PCM
  v.setUint16(22, c, true);
  v.setUint32(24, RATE, true);
  v.setUint32(28, RATE * 2 * c, true);
  v.setUint16(32, 2 * c, true);
  v.setUint16(34, 16, true);
  text(36, 'data');
  v.setUint32(40, n * 2 * c, true);
  for (let i = 0, at = 44; i < n; ++i)
    for (let ch = 0; ch < c; ++ch, at += 2)
      v.setInt16(at, Math.max(-32768, Math.min(32767, Math.round(channels[ch][i] * 32767))), true);
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

// worker: the stream worker. options: mic (send the microphone), muted (start muted), pushToTalk
// (send only while setTalking(true)), volumes (Map: display name -> gain), processing (false:
// without the browser's echo cancellation, noise suppression and gain control, for a headset or
// a speakerphone that does its own), record (keep what is played, stereo, and what the
// microphone gave, up to this many seconds: heard(), captured()).
export class Voice {
  constructor(session, worker, nowServerUs, options) {
    this.session = session;
    this.worker = worker;
    this.nowServerUs = nowServerUs;
    this.options = options;
    this.muted = !!options.muted;
    this.talking = false;
    this.speakers = new Map();  // id -> {node, gain, panner, volume}
    this.gains = new Map();     // id -> gain set here (setVolume), for speakers heard or not yet
    this.stats = {};            // the worker's (voice_worker.js voiceStats)
    this.error = '';
    this.recorded = [[], []];
    this.recordedSamples = 0;
    this.recordedAt = [];      // [sample in the recording, the context's sample] per block
    this.playedLog = [];       // [id, context sample, sender's sample] per quantum played
    this.ctx = null;
    this.mic = false;
    this.followedAt = 0;  // performance.now() of the last follow()
  }

  // Opens the audio context and, with options.mic, the microphone. Throws (the page shows it)
  // when the browser has no audio worklets or microphone; listening goes on without the latter.
  async start() {
    this.ctx = new AudioContext({sampleRate: RATE, latencyHint: 'interactive'});
    // A browser may keep the context suspended until a person touches the page.
    const resume = () => { if (this.ctx.state !== 'running') this.ctx.resume(); };
    for (const e of ['pointerdown', 'keydown']) window.addEventListener(e, resume);
    await this.ctx.audioWorklet.addModule('voice_worklet.js');
    this.master = this.ctx.createGain();
    this.master.connect(this.ctx.destination);
    if (this.options.record > 0) {
      const tap = new AudioWorkletNode(this.ctx, 'volcast-tap', {
        numberOfInputs: 1, numberOfOutputs: 0, channelCount: 2, channelCountMode: 'explicit'});
      tap.port.onmessage = (e) => this.keep(e.data);
      this.master.connect(tap);
    }
    let capture = null;
    if (this.options.mic) {
      try {
        capture = await this.openMic();
      } catch (err) {
        this.error = `microphone: ${err.name || 'Error'}: ${err.message}`;
      }
    }
    this.sendClock();
    this.clockTimer = setInterval(() => this.sendClock(), 1000);
    this.worker.postMessage({type: 'voice', capture, muted: this.muted,
                             pushToTalk: !!this.options.pushToTalk, keep: this.options.record},
                            capture ? [capture] : []);
    this.sendState();
  }

  // The microphone into the capture worklet, whose frames go to the worker on the returned port.
  async openMic() {
    const on = this.options.processing !== false;
    this.stream = await navigator.mediaDevices.getUserMedia(
        {audio: {echoCancellation: on, noiseSuppression: on, autoGainControl: on, channelCount: 1}});
    const settings = this.stream.getAudioTracks()[0].getSettings();
    this.inputLatencyS = settings.latency || 0;
    // What the browser applied (it may refuse a constraint): shown in summary().
    this.processing = {echoCancellation: !!settings.echoCancellation,
                       noiseSuppression: !!settings.noiseSuppression,
                       autoGainControl: !!settings.autoGainControl};
    const node = new AudioWorkletNode(this.ctx, 'volcast-capture', {numberOfOutputs: 0});
    const channel = new MessageChannel();
    node.port.postMessage(channel.port1, [channel.port1]);
    this.ctx.createMediaStreamSource(this.stream).connect(node);
    this.mic = true;
    return channel.port2;
  }

  // The server clock of a context time, for the worker: the output timestamp maps context to page
  // time; a sample the capture worklet processes at context time t was taken the input and
  // output latencies before it would play.
  sendClock() {
    const ts = this.ctx.getOutputTimestamp();
    const outputS = this.ctx.baseLatency + (this.ctx.outputLatency || 0);
    const serverUs = this.nowServerUs() + (ts.performanceTime - performance.now()) * 1000 -
                     (outputS + (this.inputLatencyS || 0)) * 1e6;
    this.worker.postMessage({type: 'voice-clock', contextTime: ts.contextTime, serverUs,
                             outputLatencyS: outputS});
  }

  sendState() {
    this.worker.postMessage({type: 'voice-state', joined: !!this.session.joined, muted: this.muted,
                             talking: this.talking});
  }
  setMuted(muted) {
    this.muted = muted;
    this.session.voiceState(muted);
    this.sendState();
  }
  setTalking(talking) {
    if (talking === this.talking) return;
    this.talking = talking;
    this.sendState();
  }
  // Sets the gain speaker `id` plays at here (1: as sent); kept for a speaker not heard yet.
  setVolume(id, gain) {
    this.gains.set(id, gain);
    const s = this.speakers.get(id);
    if (!s) return;
    s.volume = gain;
    s.gain.gain.value = gain;
  }
  // The gain participant `id` (display name `name`) plays at: setVolume's, else options.volumes'.
  volume(id, name) {
    if (this.gains.has(id)) return this.gains.get(id);
    return this.options.volumes?.get(name) ?? 1;
  }

  // The worker heard a new speaker: its playout worklet and place in the room.
  addSpeaker(id) {
    if (!this.ctx || this.speakers.has(id)) return;
    const log = this.options.record > 0;
    const node = new AudioWorkletNode(this.ctx, 'volcast-playout', {numberOfInputs: 0,
                                      outputChannelCount: [1], processorOptions: {log}});
    if (log) {
      node.port.onmessage = (e) => {
        for (let i = 0; i + 1 < e.data.length; i += 2)
          this.playedLog.push([id, e.data[i], e.data[i + 1]]);
      };
    }
    const gain = this.ctx.createGain();
    const panner = new PannerNode(this.ctx, {panningModel: 'HRTF', distanceModel: 'inverse',
                                             refDistance: 1, rolloffFactor: 1});
    node.connect(gain).connect(panner).connect(this.master);
    const channel = new MessageChannel();
    node.port.postMessage(channel.port1, [channel.port1]);
    this.worker.postMessage({type: 'voice-speaker', id, port: channel.port2}, [channel.port2]);
    this.speakers.set(id, {node, gain, panner, volume: 1});
    // Placed at once, not at the next frame: a loaded machine's page may draw one a few seconds
    // apart, and a new voice would sit on the listener's head (heard in the middle) until then.
    this.placeSpeaker(id, this.speakers.get(id), this.ctx.currentTime);
    const name = this.session.others.get(id)?.name;
    if (this.gains.has(id)) this.setVolume(id, this.gains.get(id));
    else if (name && this.options.volumes?.has(name)) this.setVolume(id, this.options.volumes.get(name));
  }

  // Each frame: the listener at the head (room frame: position, orientation quaternion x y z w),
  // each speaker at theirs.
  place(head) {
    if (!this.ctx || !this.master) return;
    const l = this.ctx.listener;
    const [x, y, z, w] = head.orientation;
    // The head's -z (forward) and +y (up) in the room.
    const fwd = [-2 * (x * z + w * y), -2 * (y * z - w * x), -(1 - 2 * (x * x + y * y))];
    const up = [2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)];
    const t = this.ctx.currentTime;
    [l.positionX, l.positionY, l.positionZ].forEach((p, i) => p.setValueAtTime(head.position[i], t));
    [l.forwardX, l.forwardY, l.forwardZ].forEach((p, i) => p.setValueAtTime(fwd[i], t));
    [l.upX, l.upY, l.upZ].forEach((p, i) => p.setValueAtTime(up[i], t));
    for (const [id, s] of this.speakers) this.placeSpeaker(id, s, t);
  }
  // Between frames (a loaded machine's page may draw seconds apart), after a session message: the
  // speakers where the session's newest poses have them, at most every 100 ms.
  follow() {
    if (!this.ctx || !this.master) return;
    const now = performance.now();
    if (now - this.followedAt < 100) return;
    this.followedAt = now;
    for (const [id, s] of this.speakers) this.placeSpeaker(id, s, this.ctx.currentTime);
  }
  // Speaker `id`'s panner at context time `t`: the OR site above the table; a participant at its
  // head, or standing at its spot before its first pose (a replay's recorded speakers never send
  // one); left where it is when the session does not know it (yet).
  placeSpeaker(id, s, t) {
    const p = this.session.others.get(id);
    const at = id === SITE_ID ? SITE_POSITION
               : p?.body ? p.body.head.position : p ? [p.spot.x, 1.6, p.spot.z] : null;
    if (!at) return;
    [s.panner.positionX, s.panner.positionY, s.panner.positionZ]
        .forEach((q, i) => q.setValueAtTime(at[i], t));
  }

  speaking(id) { return !!this.stats.heard?.[id]?.speaking; }

  keep({frame, out: block}) {
    if (this.recordedSamples >= this.options.record * RATE) return;
    this.recordedAt.push([this.recordedSamples, frame, block[0].length]);
    this.recorded[0].push(block[0]);
    this.recorded[1].push(block[1]);
    this.recordedSamples += block[0].length;
  }

  // The context time (s) up to which what was played is kept (record > 0; tests): the end of the
  // tap's newest block posted.
  keptTo() {
    const last = this.recordedAt[this.recordedAt.length - 1];
    return last ? (last[1] + last[2]) / RATE : 0;
  }

  // What was played since start (stereo, 48 kHz) as a 16-bit WAV file, base64 (tests).
  heard() {
    const join = (blocks) => {
      const out = new Float32Array(this.recordedSamples);
      let at = 0;
      for (const b of blocks) { out.set(b, at); at += b.length; }
      return out;
    };
    return wavBase64([join(this.recorded[0]), join(this.recorded[1])]);
  }

  // What the microphone gave the page (mono, 48 kHz; the first `record` seconds), its frame f at
  // sample f x 960 (the frame numbers its packets carry), as a 16-bit WAV file, base64 (tests).
  captured() {
    return new Promise((resolve) => {
      this.onCaptured = (samples) => resolve(wavBase64([samples]));
      this.worker.postMessage({type: 'voice-captured'});
    });
  }

  // The played log of what heard() holds (tests): one line per 128-sample quantum a speaker
  // played audio in: the quantum's first sample in heard()'s file, the speaker's id, and the
  // speaker's sample there (its frame number x 960 + the offset in the frame; the quantum's
  // sample j is the speaker's sample + j). Tab-separated text.
  heardLog() {
    const lines = [];
    let b = 0;
    for (const [id, frame, cursor] of [...this.playedLog].sort((x, y) => x[1] - y[1])) {
      while (b < this.recordedAt.length &&
             this.recordedAt[b][1] + this.recordedAt[b][2] <= frame) ++b;
      if (b === this.recordedAt.length) break;
      const [at, from, n] = this.recordedAt[b];
      if (frame >= from && frame + 128 <= from + n) lines.push(`${at + frame - from}\t${id}\t${cursor}\n`);
    }
    return lines.join('');
  }

  // What window.volcast.voice shows: the worker's figures, names and this side's state.
  summary() {
    const heard = {};
    for (const [id, h] of Object.entries(this.stats.heard || {})) {
      const p = this.session.others.get(Number(id));
      heard[id] = {...h, name: p?.name || '', muted: !!p?.muted,
                   volume: this.speakers.get(Number(id))?.volume ?? 1};
    }
    return {...this.stats, started: !!this.ctx, mic: this.mic && !!this.stats.mic, muted: this.muted,
            talking: this.talking, error: this.error || this.stats.error || '', heard,
            processing: this.processing || null, contextTime: this.ctx ? this.ctx.currentTime : 0,
            keptTo: this.keptTo(),
            keptFull: this.recordedSamples >= (this.options.record || 0) * RATE};
  }
}
