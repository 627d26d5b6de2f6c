// The voice's network side, in the stream worker (worker.js loads it), off the page's main thread
// (which a slow GPU can hold for a hundred milliseconds a frame): the microphone's 20 ms frames
// come straight from the capture worklet (a MessagePort), are encoded by WebCodecs' Opus encoder
// (48 kHz mono, 32 kbit/s VBR, in-band FEC) and sent as Voice (0x0e); each speaker's forwarded
// packets (0x4e) are decoded by WebCodecs' Opus decoder and posted straight to that speaker's
// playout worklet (voice_worklet.js). Chromium numbers its encoder's and decoder's outputs by
// counting them, not by the input they came from (with Opus DTX it drops frames and the numbers
// slide): each output here is matched to its input in order instead, one for one, and DTX is done
// here: a frame is not sent when it and the 9 before it (200 ms, as libopus waits) are all below
// -60 dBFS. Wire:
// src/session/include/volcast/session/voice_messages.hpp. A lost packet (a gap in the sequence
// numbers) is concealed by the last frame repeated 6 dB lower each time; a gap in the frame
// numbers alone is DTX silence. Mouth-to-ear latency per frame: the server clock when it is
// decoded minus its capture time, plus what waits before it in the playout buffer and the audio
// output's latency.
//
// From the page: {type: 'voice', capture: MessagePort | null, muted, pushToTalk, keep (seconds of
//   the microphone's frames to keep, by frame number: tests)}; {type: 'voice-captured'} (answered
//   with {type: 'voice-captured', samples: Float32Array}: the frames kept, frame f at f x 960,
//   zeros where none);
//   {type: 'voice-state', joined, muted, talking}; {type: 'voice-clock', contextTime, serverUs}
//   (the server clock of the audio context's time, minus the input and output latencies: a
//   sample the capture worklet stamps `contextTime` was taken at `serverUs`), outputLatencyS;
//   {type: 'voice-speaker', id, port (MessagePort to its playout worklet)}.
// To the page: {type: 'voice-speaker-needed', id}; {type: 'voice-stats', stats} (4 a second).
'use strict';

const VOICE_RATE = 48000;
const VOICE_FRAME = 960;       // samples, 20 ms
const VOICE_FRAME_US = 20000;
const VOICE_MAX_OPUS = 1275;   // RFC 6716 §3.4
const VOICE_SPEAKING_DBFS = -45;  // as src/voice/level.hpp: the loudest 20 ms of the last 300 ms
const VOICE_ENCODER = {codec: 'opus', sampleRate: VOICE_RATE, numberOfChannels: 1, bitrate: 32000,
                       bitrateMode: 'variable',
                       opus: {application: 'voip', signal: 'voice', frameDuration: VOICE_FRAME_US,
                              useinbandfec: true, usedtx: false, packetlossperc: 5, complexity: 9}};
const VOICE_SILENT_DBFS = -60;
const VOICE_HANGOVER_FRAMES = 10;
const VOICE_DECODER = {codec: 'opus', sampleRate: VOICE_RATE, numberOfChannels: 1};
// About 8 of the largest voice packets: a packet behind more in the socket is dropped (late
// audio is worse than a gap the receiver conceals).
const VOICE_BACKLOG_BYTES = 8 * 1300;

const voice = {
  on: false, joined: false, muted: false, pushToTalk: false, talking: false, error: '',
  encoder: null, frame: 0, sequence: 0,
  fed: [],  // {frame, captureUs, send} of the frames given to the encoder, oldest first
  loudAt: -1e9,  // the newest frame at or above VOICE_SILENT_DBFS
  clock: null, outputLatencyS: 0,
  sent: {packets: 0, bytes: 0, frames: 0, dtxFrames: 0, dropped: 0, firstUs: 0, lastUs: 0},
  speakers: new Map(),  // id -> speaker (voiceSpeaker)
  malformed: 0,
  micDbfs: -120, micPeakDbfs: -120,  // the microphone's newest and loudest frame (RMS)
  kept: [], keepFrames: 0,  // the microphone's frames by number, the first keepFrames (tests)
};

function voicePercentile(a, p) {
  if (!a.length) return 0;
  const s = [...a].sort((x, y) => x - y);
  return s[Math.min(s.length - 1, Math.floor(p * s.length))];
}

async function voiceStart(m) {
  voice.on = true;
  voice.muted = !!m.muted;
  voice.pushToTalk = !!m.pushToTalk;
  voice.keepFrames = Math.round((m.keep || 0) * VOICE_RATE / VOICE_FRAME);
  setInterval(() => postMessage({type: 'voice-stats', stats: voiceStats()}), 250);
  if (!m.capture) return;
  try {
    const support = await AudioEncoder.isConfigSupported(VOICE_ENCODER);
    if (!support.supported) throw new Error('this browser cannot encode Opus (WebCodecs)');
    voice.encoder = new AudioEncoder({output: voiceEncoded,
                                      error: (e) => { voice.error = `Opus encoder: ${e.message}`; }});
    voice.encoder.configure(support.config);
    m.capture.onmessage = (e) => voiceCaptured(e.data.samples, e.data.time);
  } catch (err) {
    voice.error = err.message;
  }
}

function voiceCaptured(samples, time) {
  const frame = voice.frame++;
  ++voice.sent.frames;
  if (frame < voice.keepFrames) voice.kept[frame] = samples;  // AudioData below copies them
  let e = 0;
  for (let i = 0; i < samples.length; ++i) e += samples[i] * samples[i];
  voice.micDbfs = 10 * Math.log10(e / samples.length + 1e-12);
  voice.micPeakDbfs = Math.max(voice.micPeakDbfs, voice.micDbfs);
  if (voice.micDbfs >= VOICE_SILENT_DBFS) voice.loudAt = frame;
  if (voice.muted || (voice.pushToTalk && !voice.talking) || !voice.joined || !voice.clock ||
      voice.encoder.state !== 'configured' || voice.fed.length > 50)
    return;
  voice.fed.push({frame, captureUs: voice.clock.serverUs + (time - voice.clock.contextTime) * 1e6,
                  send: frame - voice.loudAt < VOICE_HANGOVER_FRAMES});
  const data = new AudioData({format: 'f32-planar', sampleRate: VOICE_RATE,
                              numberOfFrames: VOICE_FRAME, numberOfChannels: 1,
                              timestamp: frame * VOICE_FRAME_US, data: samples});
  voice.encoder.encode(data);
  data.close();
}

function voiceEncoded(chunk) {
  const fed = voice.fed.shift();
  if (!fed) return;  // the encoder's flush: nothing was waiting
  const {frame, captureUs} = fed;
  if (!fed.send) {
    ++voice.sent.dtxFrames;
    return;
  }
  if (!socket || socket.readyState !== WebSocket.OPEN) return;
  if (socket.bufferedAmount > VOICE_BACKLOG_BYTES) {
    ++voice.sent.dropped;
    return;
  }
  const n = chunk.byteLength;
  const m = new Uint8Array(HEADER + 20 + n);
  const v = new DataView(m.buffer);
  v.setUint32(0, MAGIC, true);
  v.setUint16(4, VERSION, true);
  v.setUint8(6, 2);
  v.setUint8(7, 0x0e);
  v.setUint32(8, 20 + n, true);
  v.setUint32(12, ++voice.sequence, true);
  v.setUint32(16, frame, true);
  v.setBigInt64(20, BigInt(Math.round(captureUs)), true);
  v.setUint32(28, n, true);
  chunk.copyTo(m.subarray(32));
  socket.send(m);
  ++voice.sent.packets;
  voice.sent.bytes += n;
  if (!voice.sent.firstUs) voice.sent.firstUs = captureUs;
  voice.sent.lastUs = captureUs;
}

function voiceControl(m) {
  if (m.type === 'voice') voiceStart(m);
  else if (m.type === 'voice-captured') {
    const samples = new Float32Array(voice.kept.length * VOICE_FRAME);
    voice.kept.forEach((f, k) => samples.set(f, k * VOICE_FRAME));
    postMessage({type: 'voice-captured', samples}, [samples.buffer]);
  }
  else if (m.type === 'voice-state') Object.assign(voice, {joined: m.joined, muted: m.muted, talking: m.talking});
  else if (m.type === 'voice-clock') Object.assign(voice, {clock: m, outputLatencyS: m.outputLatencyS});
  else if (m.type === 'voice-speaker') {
    const s = voice.speakers.get(m.id);
    if (!s) return;
    s.port = m.port;
    s.port.onmessage = (e) => { s.playout = {...e.data, receivedMs: performance.now()}; };
    for (const m of s.waiting) s.port.postMessage(m, [m.pcm.buffer]);
    s.waiting = [];
  }
}

function voiceSpeaker(id) {
  let s = voice.speakers.get(id);
  if (s) return s;
  s = {id, decoder: null, port: null, waiting: [], last: null, lastSamples: null, pending: [],
       packets: 0, frames: 0, concealed: 0, malformed: 0, latencyMs: [], transitMs: [], loudAt: -1e9, playout: {}};
  voiceDecoder(s);
  voice.speakers.set(id, s);
  postMessage({type: 'voice-speaker-needed', id});
  return s;
}

// A decoder that met corrupt bytes is closed: a fresh one takes the next packet.
function voiceDecoder(s) {
  s.pending = [];
  s.decoder = new AudioDecoder({output: (data) => voiceDecoded(s, data),
                                error: () => { ++s.malformed; voiceDecoder(s); }});
  s.decoder.configure(VOICE_DECODER);
}

// Frame `frame` (the sender's numbering) to the playout worklet; `spurt`: the first after a DTX
// silence (or the first of all), where the worklet may set its delay anew.
function voicePlay(s, pcm, frame, spurt = false) {
  const m = {pcm, frame, spurt};
  if (s.port) s.port.postMessage(m, [pcm.buffer]);
  else if (s.waiting.length < 10) s.waiting.push(m);
}

// A forwarded packet (0x4e): participant u32 | sequence u32 | frame u32 | capture i64 | Opus (u32
// length + bytes). A malformed one is counted and dropped.
function voiceReceive(payload) {
  if (!voice.on) return;
  const v = new DataView(payload.buffer, payload.byteOffset, payload.byteLength);
  if (payload.length < 24) return void ++voice.malformed;
  const n = v.getUint32(20, true);
  if (n < 1 || n > VOICE_MAX_OPUS || payload.length !== 24 + n) return void ++voice.malformed;
  const p = {sequence: v.getUint32(4, true), frame: v.getUint32(8, true),
             captureUs: Number(v.getBigInt64(12, true))};
  const s = voiceSpeaker(v.getUint32(0, true));
  if (s.last && p.sequence <= s.last.sequence) return;  // old or repeated
  let spurt = !s.last;
  if (s.last) {
    // Lost packets: the frames just before this one (a longer gap in the frame numbers is DTX).
    const lost = Math.min(p.sequence - s.last.sequence - 1, p.frame - s.last.frame - 1, 25);
    spurt = p.frame - s.last.frame - 1 > Math.max(lost, 0);
    for (let k = 0; k < lost; ++k) {
      const out = new Float32Array(VOICE_FRAME);
      if (s.lastSamples) for (let i = 0; i < VOICE_FRAME; ++i) out[i] = s.lastSamples[i] * 0.5 ** (k + 1);
      ++s.concealed;
      voicePlay(s, out, p.frame - lost + k);
    }
  }
  s.last = p;
  ++s.packets;
  s.transitMs.push((wallUs() + clockOffsetUs - p.captureUs) / 1000);
  if (s.transitMs.length > 3000) s.transitMs.shift();
  if (s.pending.length > 50) return void voiceDecoder(s);  // a decoder that stopped answering
  s.pending.push({captureUs: p.captureUs, frame: p.frame, spurt});
  s.decoder.decode(new EncodedAudioChunk({type: 'key', timestamp: p.frame * VOICE_FRAME_US,
                                          data: payload.subarray(24)}));
}

function voiceDecoded(s, data) {
  const pending = s.pending.shift();
  if (!pending) return void data.close();
  const out = new Float32Array(data.numberOfFrames);
  data.copyTo(out, {planeIndex: 0, format: 'f32-planar'});
  data.close();
  ++s.frames;
  s.lastSamples = out.slice(0, VOICE_FRAME);
  let e = 0;
  for (let i = 0; i < out.length; ++i) e += out[i] * out[i];
  if (10 * Math.log10(e / out.length + 1e-12) > VOICE_SPEAKING_DBFS) s.loudAt = performance.now();
  // Its wait in the playout buffer: from the worklet's cursor (reported every 100 ms, moved on
  // by the time since) to the frame's first sample.
  if (s.playout.cursor !== undefined) {
    const cursor = s.playout.cursor + (performance.now() - s.playout.receivedMs) * VOICE_RATE / 1000;
    const waitMs = ((pending.frame * VOICE_FRAME - cursor) / VOICE_RATE + voice.outputLatencyS) * 1000;
    s.latencyMs.push((wallUs() + clockOffsetUs - pending.captureUs) / 1000 + Math.max(0, waitMs));
    if (s.latencyMs.length > 3000) s.latencyMs.shift();
  }
  voicePlay(s, out, pending.frame, pending.spurt);
}

// What the page shows (window.volcast.voice), by speaker id.
function voiceStats() {
  const heard = {};
  const now = performance.now();
  for (const s of voice.speakers.values())
    heard[s.id] = {packets: s.packets, frames: s.frames, concealed: s.concealed,
                   malformed: s.malformed,
                   concealedPercent: (100 * s.concealed) / Math.max(1, s.frames + s.concealed),
                   latencyMsP50: voicePercentile(s.latencyMs, 0.5),
                   latencyMsP99: voicePercentile(s.latencyMs, 0.99),
                   transitMsP50: voicePercentile(s.transitMs, 0.5),
                   transitMsP99: voicePercentile(s.transitMs, 0.99),
                   speaking: now - s.loudAt < 300, late: s.playout.late || 0,
                   skippedMs: (s.playout.skipped || 0) / 48, delayMs: (s.playout.target || 0) / 48,
                   resumed: s.playout.resumed || 0, insertedMs: (s.playout.inserted || 0) / 48,
                   restarts: s.playout.restarts || 0, waitingMs: (s.playout.ahead || 0) / 48};
  const t = voice.sent;
  const seconds = (t.lastUs - t.firstUs) / 1e6;
  return {mic: !!voice.encoder, error: voice.error, packetsSent: t.packets, framesCaptured: t.frames,
          dtxFrames: t.dtxFrames, droppedBehindSocket: t.dropped,
          bytesPerSecond: seconds > 0 ? t.bytes / seconds : 0, micDbfs: voice.micDbfs,
          micPeakDbfs: voice.micPeakDbfs, badPackets: voice.malformed, heard};
}
