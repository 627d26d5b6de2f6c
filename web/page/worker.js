// The browser viewer's stream worker: the WebSocket to `volcast serve --web`, the Volcast
// protocol (protocol.hpp, its version from messages.js: the same bytes as a native viewer's TLS
// stream, each message one binary WebSocket message or split across several; its bytes in
// stream_wire.js, the colour balance in balance_worker.js), and decoding: depth by Volcast's own
// codecs in WebAssembly (volcast_decoder.wasm), color JPEG by createImageBitmap, H.264 through
// WebCodecs (a KeyFrameRequest when it has no key frame to start from or fails), raw by hand.
// Session messages (channel 2) pass to the page, but the others' camera avatars (0x49, 0x4a),
// the case (0x4b, case_wire.js) and the others' voices (0x4e, voice_worker.js), taken here; this
// page's voice is encoded and sent from here too.
//
// Messages from the page: {type: 'start', url, token (32 hex), depth, color, quality, adapt,
//   floor ('lossless' or ''), maxRate (bits/s, 0: none), check}
//   ({check: true}: each decoded depth image's FNV-1a 32 hash is reported, for tests);
//   {type: 'send', bytes (ArrayBuffer: a whole message, header included)}; {type: 'bench', runs};
//   voice control (voice_worker.js).
//   Once the page sends a join, the worker sends the session heartbeat itself (presence below).
// Messages to the page: {type: 'welcome', cameras: [{width, height, intrinsics (15 numbers),
//   rotation (9, row-major), translation (3), name, rays (Float32Array, 2 per pixel)}],
//   clockOffsetUs}; {type: 'frames', sequence, key, captureUs, cameras: [{depth (Uint16Array) |
//   null, width, height, color (ImageBitmap) | null, hash}], decodeMs, depthDecodeMs,
//   receivedUs, gains ([[r, g, b]] per camera: the colour balance, every 15 new images, else
//   absent)}; {type: 'session', bytes (ArrayBuffer: header + payload)}; {type: 'error', what};
//   {type: 'closed', why}; {type: 'bench', result: {runs, medianMs, minMs, stream (base64)}};
//   {type: 'avatar-camera', id, camera (as in welcome, playarea_from_camera, + depthCodec,
//   colorCodec)}; {type: 'avatar', id, sequence, captureUs, depth, color}; {type: 'avatar-error',
//   id, what}; {type: 'warning', what}; {type: 'case', case (case_wire.js parseCase)}; voice
//   (voice_worker.js); {type: 'tier', depth, color, quality, divisor, pathMbit, reason, change}
//   (TierChange 0.6: change false is a notice); {type: 'reconnecting', why, inMs}; then
//   'welcome' again with reconnected true and outageMs; {type: 'stale', count}.
'use strict';

importScripts('messages.js', 'volcast_decoder.js', 'stream_wire.js', 'case_wire.js', 'clock.js',
              'balance_worker.js', 'voice_worker.js');


let wasm = null;
let socket = null;
let cameras = null;
let frameLimit = 0;
let check = false;
let inbox = [];  // received chunks (Uint8Array), consumed from the front
let inboxBytes = 0;
let decoding = false;
let clockOffsetUs = 0;  // the server's clock - ours (clock.js)
let helloSentUs = 0;    // when this connection's Hello went out, our clock
let start = null;  // the page's 'start' message: link, tier, adaptation
let tier = {depth: '', color: '', quality: 0, divisor: 1};  // as the server last said
// Reconnecting (as the native viewer, receiver.hpp): a connection that closes, or brings no
// message for SILENCE_MS, is cut; a new one is opened (250 ms, doubling to 2 s) with the same
// Hello, until GIVE_UP_MS. What was queued on the old one is dropped, never drawn; so is a frame
// set older than STALE_MS when it arrives.
const SILENCE_MS = 2000, GIVE_UP_MS = 300000, STALE_MS = 1000;
let generation = 0;  // one per connection: a drain of an old one stops
let lastMessageMs = 0;
let cutAt = 0;       // when the cut began (0: connected)
let retryMs = 250;
let refused = false;  // the server sent Reject: no reconnecting
let stale = 0;

const wallUs = () => (performance.timeOrigin + performance.now()) * 1000;

// The session heartbeat (0x09, empty) goes from here once a second between the page's join (0x02)
// and its leave (0x03), not from the page: a page whose main thread stalls for longer than the
// server's presence timeout (3 s by default: a loaded headset, a big upload to the GPU) stays in
// its session while its connection lives. The hub ignores a heartbeat outside a session.
let heartbeat = 0;
function presence(bytes) {
  if (bytes.length < HEADER || bytes[6] !== 2) return;
  if (bytes[7] === 0x02 && !heartbeat) {
    heartbeat = setInterval(() => {
      if (!socket || socket.readyState !== WebSocket.OPEN) return;
      const beat = new Uint8Array(HEADER);
      const v = new DataView(beat.buffer);
      v.setUint32(0, MAGIC, true);
      v.setUint16(4, VERSION, true);
      v.setUint8(6, 2);
      v.setUint8(7, 0x09);
      socket.send(beat);
    }, 1000);
  } else if (bytes[7] === 0x03 && heartbeat) {
    clearInterval(heartbeat);
    heartbeat = 0;
  }
}

function fail(what) {
  postMessage({type: 'error', what});
  if (socket) socket.close();
}

// What this page decodes: the WebAssembly decoder's depth codecs, and JPEG, raw and (with
// WebCodecs) H.264 color. An adaptive page names them in its Hello (protocol.hpp 0.1's tail), so
// that the server keeps it to ladder rungs it can show.
function decodable() {
  const depth = ['raw', 'rvl', 'trvl', 'volcast', 'volcast-t', 'volcast-n1', 'volcast-n2',
                 'volcast-n4'];
  const color = ['jpeg', 'raw', 'none'];
  if (typeof VideoDecoder !== 'undefined') color.push('h264');
  return depth.concat(color);
}

// Hello (0.1) for the page's start message `s`. `s.adapt`: the server may move this page along
// its ladder (flags: adapt + understands TierChange, + keep depth lossless for floor 'lossless';
// cap s.maxRate bits/s), within the codecs it decodes.
function hello(s) {
  const parts = [new Uint8Array(s.token.match(/../g).map((h) => parseInt(h, 16)))];
  putString(parts, s.depth);
  putString(parts, s.color);
  parts.push(new Uint8Array([s.quality]));
  const flags = (s.adapt ? 1 | 8 : 8) | (s.floor === 'lossless' ? 2 : 0);
  const tail = new Uint8Array(9);
  tail[0] = flags;
  new DataView(tail.buffer).setBigUint64(1, BigInt(Math.max(0, Math.round(s.maxRate || 0))), true);
  parts.push(tail);
  const codecs = decodable();
  parts.push(new Uint8Array([codecs.length]));
  for (const c of codecs) putString(parts, c);
  return message(0, 1, concat(parts));
}

// TierChange (0.6): the tier of the frame sets after it (a key frame set first), or a notice.
function onTierChange(payload) {
  const r = new Reader(payload, 'tier change');
  const depth = r.string(), color = r.string(), quality = r.u8(), divisor = r.u8();
  const pathKbit = r.u32();
  const reason = r.string();
  if (r.at !== payload.length) throw new Error('malformed tier change: trailing bytes');
  if (divisor < 1 || divisor > 8) throw new Error(`malformed tier change: divisor ${divisor}`);
  if (!start.adapt && (depth !== start.depth || color !== start.color))
    throw new Error('the server changed the tier of a page that pinned it');
  if (start.floor === 'lossless' && depth !== tier.depth && depth.startsWith('volcast-n'))
    throw new Error(`the server changed to lossy depth (${depth}) a page that keeps it lossless`);
  const change = depth !== tier.depth || color !== tier.color || quality !== tier.quality ||
                 divisor !== tier.divisor;
  if (change) {
    closeVideoDecoders();  // the key frame set that follows starts them again
    colorCodec = color;
  }
  tier = {depth, color, quality, divisor};
  postMessage({type: 'tier', depth, color, quality, divisor, pathMbit: pathKbit / 1000,
               reason: reason.replace(/[\x00-\x1f\x7f]/g, '?'), change});
}

function rayTable(cam) {
  const k = wasm._malloc(17 * 8);
  const n = cam.width * cam.height;
  const out = wasm._malloc(n * 8);
  wasm.HEAPF64.set([cam.width, cam.height, ...cam.intrinsics], k / 8);
  const rc = wasm._vc_ray_table(k, out);
  const rays = rc === 0 ? wasm.HEAPF32.slice(out / 4, out / 4 + 2 * n) : null;
  wasm._free(k);
  wasm._free(out);
  if (!rays) throw new Error('ray table: ' + wasm.UTF8ToString(wasm._vc_last_error()));
  return rays;
}

// FNV-1a 32 over the depth image's bytes (little-endian uint16), for the bit-exact check.
function fnv1a(depth) {
  let h = 0x811c9dc5;
  for (let i = 0; i < depth.length; ++i) {
    const v = depth[i];
    h = Math.imul(h ^ (v & 0xff), 0x01000193);
    h = Math.imul(h ^ (v >>> 8), 0x01000193);
  }
  return h >>> 0;
}

let colorCodec = 'jpeg';  // the tier's, from the page
const videoDecoders = [];  // h264 color: per camera {decoder, waiting: {resolve, reject}}
let videoTimestamp = 0;

// The H.264 codec string (RFC 6381 avc1.PPCCLL) from the stream's sequence parameter set (NAL
// type 7, Annex B start codes), or null when the frame has none.
function avcCodecString(annexB) {
  for (let i = 0; i + 6 < annexB.length; ++i) {
    if (annexB[i] === 0 && annexB[i + 1] === 0 && annexB[i + 2] === 1 &&
        (annexB[i + 3] & 0x1f) === 7) {
      const hex = (x) => x.toString(16).padStart(2, '0');
      return 'avc1.' + hex(annexB[i + 4]) + hex(annexB[i + 5]) + hex(annexB[i + 6]);
    }
  }
  return null;
}

function requestKeyFrame() {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(message(0, 5, new Uint8Array(0)));
}

// One camera's h264 color frame (the 12-byte 'V' 'C' header, then Annex B; color_codec.hpp)
// through WebCodecs: resolves to an ImageBitmap, or null while waiting for a key frame.
async function decodeH264(camera, stream) {
  if (stream.length < 12 || stream[0] !== 0x56 || stream[1] !== 0x43 || stream[3] !== 2)
    throw new Error(`camera ${camera}: not an h264 color stream`);
  const key = (stream[4] & 1) === 1;
  const data = stream.subarray(12);
  let d = videoDecoders[camera];
  if (!d || d.decoder.state === 'closed') {
    const codec = key ? avcCodecString(data) : null;
    if (!codec) {
      requestKeyFrame();
      return null;
    }
    d = {waiting: null};
    d.decoder = new VideoDecoder({
      output: (frame) => {
        const w = d.waiting;
        d.waiting = null;
        createImageBitmap(frame).then((b) => { frame.close(); if (w) w.resolve(b); else b.close(); },
                                      (e) => { frame.close(); if (w) w.reject(e); });
      },
      error: (e) => {
        if (d.waiting) d.waiting.resolve(null);
        d.waiting = null;
        postMessage({type: 'warning', what: `camera ${camera}: h264 decoder: ${e.message}`});
        requestKeyFrame();
      },
    });
    d.decoder.configure({codec, optimizeForLatency: true});
    videoDecoders[camera] = d;
  }
  return new Promise((resolve, reject) => {
    d.waiting = {resolve, reject};
    d.decoder.decode(new EncodedVideoChunk({type: key ? 'key' : 'delta',
                                            timestamp: ++videoTimestamp, data}));
    setTimeout(() => { if (d.waiting && d.waiting.resolve === resolve) { d.waiting = null; resolve(null); } }, 1000);
  });
}

// One camera's color stream of the tier's codec: an ImageBitmap, or null for no color.
function decodeColor(camera, stream) {
  if (!stream.length) return Promise.resolve(null);
  if (colorCodec === 'jpeg')
    return createImageBitmap(new Blob([stream], {type: 'image/jpeg'}), {imageOrientation: 'none'});
  if (colorCodec === 'h264') return decodeH264(camera, stream);
  if (colorCodec === 'raw') {
    const w = stream[8] | (stream[9] << 8), h = stream[10] | (stream[11] << 8);
    if (stream.length !== 12 + w * h * 4) throw new Error(`camera ${camera}: raw color of the wrong size`);
    const rgba = new Uint8ClampedArray(w * h * 4);
    for (let i = 0; i < w * h * 4; i += 4) {
      rgba[i] = stream[12 + i + 2];
      rgba[i + 1] = stream[12 + i + 1];
      rgba[i + 2] = stream[12 + i];
      rgba[i + 3] = 255;
    }
    return createImageBitmap(new ImageData(rgba, w, h));
  }
  return Promise.resolve(null);  // none
}

let lastStream = null;  // camera 0's newest depth stream (for bench)
let input = null;  // scratch in the module's memory for one depth stream
let inputBytes = 0;

function decodeDepth(camera, stream, cam = cameras[camera], slot = camera) {
  if (stream.length > inputBytes) {
    if (input) wasm._free(input);
    inputBytes = Math.max(stream.length, 1 << 20);
    input = wasm._malloc(inputBytes);
  }
  wasm.HEAPU8.set(stream, input);
  const n = wasm._vc_decode_depth(slot, input, stream.length);
  if (n < 0) throw new Error(`camera ${camera}: ` + wasm.UTF8ToString(wasm._vc_last_error()));
  const w = wasm._vc_last_width(), h = wasm._vc_last_height();
  if (w !== cam.width || h !== cam.height)
    throw new Error(`camera ${camera}: depth ${w}x${h}, calibrated ${cam.width}x${cam.height}`);
  const p = wasm._vc_last_pixels() / 2;
  return wasm.HEAPU16.slice(p, p + n);
}

async function onFrameSet(payload, receivedUs) {
  const r = new Reader(payload, 'frame set');
  r.i64();  // the server's send time
  const sequence = r.u64();
  const key = (r.u8() & 1) === 1;
  const captureUs = r.i64();
  r.i64();
  r.i64();
  const n = r.u32();
  if (n !== cameras.length) throw new Error(`frame set: ${n} cameras, the site has ${cameras.length}`);
  const streams = [];
  for (let c = 0; c < n; ++c) {
    r.i64();  // device timestamp
    const depth = r.bytes(r.u32());
    const color = r.bytes(r.u32());
    streams.push({depth, color});
  }
  const t0 = performance.now();
  const colors = streams.map((s, c) => decodeColor(c, s.color));
  // Kept by reference (the payload is this message's own buffer, never reused): no copy.
  if (streams[0].depth.length) lastStream = streams[0].depth;
  const out = [];
  for (let c = 0; c < n; ++c) {
    const depth = streams[c].depth.length ? decodeDepth(c, streams[c].depth) : null;
    out.push({depth, width: cameras[c].width, height: cameras[c].height, color: null,
              hash: check && depth ? fnv1a(depth) : 0});
  }
  const depthDecodeMs = performance.now() - t0;
  const bitmaps = await Promise.all(colors);
  bitmaps.forEach((b, c) => { out[c].color = b; });
  const decodeMs = performance.now() - t0;
  balanceCountdown -= out.filter((c) => c.depth).length;
  const gains = balanceCountdown <= 0 ? balanceGains(out, bitmaps) : null;
  if (gains) balanceCountdown = BALANCE_EVERY;
  if (socket.readyState !== WebSocket.OPEN) return;
  socket.send(message(0, 4, (() => {
    const a = new Uint8Array(8);
    new DataView(a.buffer).setBigUint64(0, BigInt(sequence), true);
    return a;
  })()));
  if (wallUs() + clockOffsetUs - captureUs > STALE_MS * 1000) {  // queued on a stalled path
    for (const c of out) if (c.color) c.color.close();
    postMessage({type: 'stale', count: ++stale});
    return;
  }
  const transfer = [];
  for (const c of out) {
    if (c.depth) transfer.push(c.depth.buffer);
    if (c.color) transfer.push(c.color);
  }
  postMessage({type: 'frames', sequence, key, captureUs, cameras: out, decodeMs, depthDecodeMs,
               receivedUs, ...(gains ? {gains} : {})}, transfer);
}

// The others' camera avatars (messages.hpp 0x49, 0x4a): calibrations by participant, and the
// newest frame of each waiting to be decoded (older ones are dropped, as the server does).
const avatarCameras = new Map();
const avatarWaiting = new Map();
let avatarBusy = false;
const AVATAR_SLOTS = 31;  // decoders 32..62 (63 is the benchmark's)

function onAvatarCamera(payload) {
  const r = new Reader(payload, 'avatar camera');
  const id = r.u32();
  const cam = readCalibration(r, 'avatar camera');
  if (cam.width > 2048 || cam.height > 2048) throw new Error('avatar camera larger than 2048 px');
  cam.depthCodec = r.string();
  cam.colorCodec = r.string();
  cam.rays = rayTable(cam);
  cam.slot = 32 + (avatarCameras.size % AVATAR_SLOTS);
  wasm._vc_reset(cam.slot);
  avatarCameras.set(id, cam);
  postMessage({type: 'avatar-camera', id, camera: cam});
}

async function decodeAvatars() {
  if (avatarBusy) return;
  avatarBusy = true;
  try {
    while (avatarWaiting.size) {
      const [id, payload] = avatarWaiting.entries().next().value;
      avatarWaiting.delete(id);
      const cam = avatarCameras.get(id);
      if (!cam) continue;
      const r = new Reader(payload, 'avatar frame');
      r.u32();
      const sequence = r.u64();
      const captureUs = r.i64();
      const depthBytes = r.bytes(r.u32());
      const colorBytes = r.bytes(r.u32());
      let depth = null;
      try {
        depth = decodeDepth(id, depthBytes, cam, cam.slot);
      } catch (e) {
        postMessage({type: 'avatar-error', id, what: e.message});
        continue;
      }
      const color = colorBytes.length && cam.colorCodec === 'jpeg'
          ? await createImageBitmap(new Blob([colorBytes], {type: 'image/jpeg'}))
          : null;
      postMessage({type: 'avatar', id, sequence, captureUs, depth, color},
                  color ? [depth.buffer, color] : [depth.buffer]);
    }
  } finally {
    avatarBusy = false;
  }
}

function take(n) {
  const out = new Uint8Array(n);
  let at = 0;
  while (at < n) {
    const head = inbox[0];
    const k = Math.min(head.length, n - at);
    out.set(head.subarray(0, k), at);
    at += k;
    if (k === head.length) inbox.shift();
    else inbox[0] = head.subarray(k);
  }
  inboxBytes -= n;
  return out;
}

function peekHeader() {
  const h = inbox[0].length >= HEADER ? inbox[0].subarray(0, HEADER) : (() => {
    const t = take(HEADER);
    inbox.unshift(t);
    inboxBytes += HEADER;
    return t;
  })();
  const v = new DataView(h.buffer, h.byteOffset, HEADER);
  if (v.getUint32(0, true) !== MAGIC) throw new Error('bad magic: not a Volcast server');
  if (v.getUint16(4, true) !== VERSION)
    throw new Error(`protocol version ${v.getUint16(4, true)}, this page speaks ${VERSION}`);
  return {channel: v.getUint8(6), type: v.getUint8(7), length: v.getUint32(8, true)};
}

// The largest payload of the server's session message `type` (messages.js: the C++ table's).
const {T, MESSAGES} = self.VolcastMessages;
function sessionLimit(type) {
  if (MESSAGES[type] && !MESSAGES[type].up) return MESSAGES[type].maxPayload;
  throw new Error(`the server sent session message type 0x${type.toString(16)}, which it does not send`);
}

// Parses every whole message in the inbox, in order; frame sets are decoded one at a time (the
// server paces by Acks, so few wait).
async function drain() {
  if (decoding) return;
  decoding = true;
  const g0 = generation;
  try {
    while (inboxBytes >= HEADER) {
      const h = peekHeader();
      const limit = h.channel === 2 ? sessionLimit(h.type)
                  : h.channel === 1 ? (cameras ? frameLimit : 0)
                  : h.type === 2 ? MAX_WELCOME : MAX_CONTROL;
      if (h.length > limit)
        throw new Error(`message ${h.channel}.${h.type} of ${h.length} bytes exceeds ${limit}`);
      if (inboxBytes < HEADER + h.length) break;
      const receivedUs = wallUs();
      const whole = take(HEADER + h.length);
      const payload = whole.subarray(HEADER);
      if (h.channel === 0 && h.type === 2) {
        const w = parseWelcome(payload);
        frameLimit = w.frameLimit;
        const reconnected = cameras !== null;
        if (reconnected && (w.cameras.length !== cameras.length ||
                            w.cameras.some((c, i) => c.width !== cameras[i].width ||
                                                     c.height !== cameras[i].height)))
          throw new Error(`the site came back with other cameras (${w.cameras.length})`);
        cameras = w.cameras;
        clockOffsetUs = handshakeClockOffsetUs(w.serverUs, helloSentUs, receivedUs);
        for (const c of cameras) c.rays = rayTable(c);
        setBalanceCameras();
        const outageMs = cutAt ? performance.now() - cutAt : 0;
        cutAt = 0;
        retryMs = 250;
        postMessage({type: 'welcome', cameras, clockOffsetUs, reconnected, outageMs});
      } else if (h.channel === 0 && h.type === 3) {
        refused = true;
        throw new Error('the server refused: ' + new Reader(payload, 'reject').string());
      } else if (h.channel === 0 && h.type === 6) {
        onTierChange(payload);
      } else if (h.channel === 1 && h.type === 1 && cameras) {
        const g = generation;
        await onFrameSet(payload, receivedUs);
        if (g !== generation) return;  // cut meanwhile: that inbox is gone
      } else if (h.channel === 2 && h.type === T.CASE) {
        const c = parseCase(payload);
        postMessage({type: 'case', case: c}, caseBuffers(c));
      } else if (h.channel === 2 && h.type === T.AVATAR_CAMERA_FROM) {
        onAvatarCamera(payload);
      } else if (h.channel === 2 && h.type === T.AVATAR_FRAME_FROM) {
        if (payload.length < 4) throw new Error('malformed avatar frame: truncated');
        const id = new DataView(payload.buffer, payload.byteOffset, 4).getUint32(0, true);
        avatarWaiting.set(id, payload);
        decodeAvatars();
      } else if (h.channel === 2 && h.type === T.VOICE_FROM) {
        voiceReceive(payload);
      } else if (h.channel === 2) {
        postMessage({type: 'session', bytes: whole.buffer}, [whole.buffer]);
      } else {
        throw new Error(`unexpected message ${h.channel}.${h.type}`);
      }
    }
  } catch (e) {
    fail(e.message);
    if (socket) {
      socket.onclose = null;
      socket.close();
    }
    refused = true;  // a broken stream is not a cut: no reconnecting
  } finally {
    if (g0 === generation) decoding = false;  // else cut() reset it for the new connection
  }
  if (inboxBytes >= HEADER && socket && socket.readyState === WebSocket.OPEN) drain();
}

// Decodes camera 0's newest depth stream `runs` times (the same bytes, a key frame of a
// non-temporal codec) and reports the median time per decode, with the bytes, so that a native
// decode of the same frame can be timed beside it (tests/web_test.cpp).
function bench(runs) {
  if (!lastStream) return {error: 'no frame yet'};
  const times = [];
  for (let i = 0; i < runs; ++i) {
    const t0 = performance.now();
    wasm.HEAPU8.set(lastStream, input);
    const n = wasm._vc_decode_depth(63, input, lastStream.length);
    times.push(performance.now() - t0);
    if (n < 0) return {error: wasm.UTF8ToString(wasm._vc_last_error())};
  }
  times.sort((a, b) => a - b);
  let binary = '';
  for (const b of lastStream) binary += String.fromCharCode(b);
  return {runs, medianMs: times[times.length >> 1], minMs: times[0], stream: btoa(binary)};
}

onmessage = async (e) => {
  const m = e.data;
  if (m.type === 'bench') {
    postMessage({type: 'bench', result: bench(m.runs)});
    return;
  }
  if (m.type.startsWith('voice')) {
    voiceControl(m);
    return;
  }
  if (m.type === 'send') {
    if (socket && socket.readyState === WebSocket.OPEN) {
      presence(new Uint8Array(m.bytes));
      socket.send(m.bytes);
    }
    return;
  }
  if (m.type !== 'start') return;
  check = !!m.check;
  colorCodec = m.color;
  if (colorCodec === 'h264' && typeof VideoDecoder === 'undefined') {
    fail('this browser has no WebCodecs for h264 color: open the link with &color=jpeg');
    return;
  }
  try {
    wasm = await VolcastDecoder();
  } catch (err) {
    fail('cannot load the WebAssembly decoder: ' + err);
    return;
  }
  start = m;
  tier = {depth: m.depth, color: m.color, quality: m.quality, divisor: 1};
  connect();
  setInterval(() => {  // a connection that brings nothing for SILENCE_MS is cut
    if (!cutAt && cameras && socket && socket.readyState === WebSocket.OPEN &&
        performance.now() - lastMessageMs > SILENCE_MS)
      cut(`no message from the server for ${SILENCE_MS / 1000} s`);
  }, 500);
};

function closeVideoDecoders() {
  for (const d of videoDecoders)
    if (d && d.decoder.state !== 'closed') d.decoder.close();
  videoDecoders.length = 0;
}

// Opens the stream's WebSocket and sends the Hello.
function connect() {
  const g = ++generation;
  socket = new WebSocket(start.url);
  socket.binaryType = 'arraybuffer';
  lastMessageMs = performance.now();
  socket.onopen = () => {
    helloSentUs = wallUs();
    socket.send(hello(start));
  };
  socket.onmessage = (ev) => {
    if (g !== generation) return;
    lastMessageMs = performance.now();
    const chunk = new Uint8Array(ev.data);
    inbox.push(chunk);
    inboxBytes += chunk.length;
    drain();
  };
  socket.onclose = (ev) => {
    if (g !== generation) return;
    if (refused) postMessage({type: 'closed', why: ev.reason || `code ${ev.code}`});
    else cut(cameras ? `the connection closed (${ev.reason || 'code ' + ev.code})`
                     : 'cannot reach the server (is it up, and its certificate accepted?)');
  };
}

// The connection is cut: drop it and what it queued, say so, and try again after retryMs.
function cut(why) {
  if (!cutAt) cutAt = performance.now();
  if (performance.now() - cutAt > GIVE_UP_MS) {
    postMessage({type: 'closed', why: `${why}; gave up reconnecting`});
    return;
  }
  ++generation;
  if (socket) {
    socket.onclose = null;
    socket.onmessage = null;
    socket.close();
  }
  inbox = [];
  inboxBytes = 0;
  decoding = false;
  closeVideoDecoders();
  if (wasm && cameras) for (let c = 0; c < cameras.length; ++c) wasm._vc_reset(c);
  postMessage({type: 'reconnecting', why, inMs: retryMs});
  setTimeout(connect, retryMs);
  retryMs = Math.min(retryMs * 2, 2000);
}
