// The browser viewer's page: opened from the link `volcast serve --web` prints
// (https://HOST:PORT/#token=...), it streams the site over a WebSocket (worker.js), draws it with
// WebGL2 (renderer.js) in the virtual OR, and joins the session as a participant (session.js):
// on a desktop with the mouse (drag to look, W/A/S/D to walk, double-click the floor to teleport),
// in a headset through WebXR immersive-vr (head and controllers published; the trigger teleports
// where the controller points on the floor).
//
// Fragment parameters: token (required, 32 hex digits), name, session (default OR), depth
// (default volcast; raw, rvl, trvl and volcast* decode here), color (default jpeg; none),
// quality, surface (mesh, the default, or splats), blend=0 (the cameras drawn plain, not blended;
// blend=1: blended however slow; without either the page blends while it keeps the display's rate:
// frame_budget.js), framems=MS (the display's frame period that budget assumes; default 1000/60,
// in a headset 1000 / its session's frame rate),
// weights=angle (blending's first weights; default reliability: the native renderer's method and
// defaults, renderer.js CAMERA_DEFAULTS), balance=0 (no colour balance between cameras), xrscale (the headset's framebuffer scale, 0.1
// to 2, default 1: lower for a slow device), check=1 (hash every decoded depth image, for tests),
// room=0 (the site's points alone, without the room and the others), fps=N (draw the desktop
// view at most N times a second: a slow machine keeps time for the rest); voice=0 (no voice), mic=0
// (listen only), muted=1 (start muted), ptt=1 (push to talk: hold V, or the left controller's X),
// processing=0 (the microphone without the browser's echo cancellation, noise suppression and
// gain control: a headset, or a speakerphone that does its own),
// volume=NAME:GAIN,... (per participant), record=S (keep S seconds of what is played, for tests),
// probe=1 (read back, every 5th frame, the colour drawn at another's pointer hit: for tests).
// Voice (voice.js): M mutes and unmutes (the left controller's Y in a headset); the others'
// voices play from where they stand; a green box over a head speaks, a red one is muted; the
// people panel (top right) lists the others with a volume slider each.
// The patient case (serve --case): its organs over the table and the CT on the wall monitor. In a
// headset, squeeze a controller's grip near an organ to hold it (it follows the hand; let go to
// release); on a desktop, G grabs the organ you look at (it follows your view) and G again lets
// it go, Z/X turn it. The monitor, for everyone: [ and ] scroll slices, 1/2/3 the abdomen, liver
// and bone windows, O the overlay.
// Pointing and drawing (session/annotations.hpp; drawing.js): everyone's laser pointer while held
// and the session's strokes, arrows and labels, in their owner's colour (monitor strokes only
// while the monitor shows their slice). On a desktop, hold L: the pointer goes from your hand
// through the mouse to what the page draws under it (Renderer.pick: the live clouds' splats, an
// organ, the monitor, the room); Shift+drag draws a stroke there (sent when let go), Alt+drag an
// arrow from where the drag began to where it ends; N pins a typed label under the mouse;
// Backspace erases your newest annotation (on the monitor's picture, they stick to its CT slice).
// In a headset (xr.js), its controllers point, draw, pin labels and erase as the native
// headset's (hand_pointing.hpp). AR (immersive-ar, where the device has it: a headset's
// passthrough at the site): the real room is seen, so the page draws only the others' avatars,
// pointers and annotations and the case's organs, placed through room_from_site of the Joined
// message (docs/usage.md says how to align them).
// The page's parts: panels.js (overlay, people, recording badge), pointing.js (pointer, drawing,
// erase), case_hold.js (the organ held, the monitor's keys), room_boxes.js, xr.js (the headset).
// window.volcast holds what the page measured, for people (the overlay) and tests.
import * as M from './math.js';
import {FrameBudget} from './frame_budget.js';
import {CaseHold} from './case_hold.js';
import {Panels} from './panels.js';
import {Pointing} from './pointing.js';
import {Renderer} from './renderer.js';
import {MONITOR_QUAD, ROOM, avatarBoxes, furnitureBoxes} from './room_boxes.js';
import {Session, T} from './session.js';
import {Voice} from './voice.js';
import {Headset} from './xr.js';

const params = new URLSearchParams(location.hash.slice(1));
const EYE_HEIGHT = 1.6;

const state = {
  phase: 'connecting', error: '', cameras: 0, framesReceived: 0, framesDrawn: 0,
  firstFrameMs: null, decodeMs: [], depthDecodeMs: [], hashes: [], latencyMs: [],
  // The last latency stage, as the native viewer's (stage_stats.hpp): ready (the decoded frame
  // set reached the page) -> presented, and capture -> presented ("photon"), ms.
  presentedMs: [], photonMs: [],
  session: null, xr: {frames: 0, views: 0, active: false, recordingBadgeFrames: 0}, tier: '', desktopFrames: 0,
  // The path (TierChange 0.6, worker.js): adapting or pinned, the server's path estimate, the
  // last 8 changes and notices; the connection ('' or 'reconnecting: why'), each cut it came back
  // from ({ms, why}), and frame sets dropped as stale.
  adaptive: false, losslessDepth: true, pathMbit: 0, tierChanges: [], connection: '',
  outages: [], framesStale: 0,
  avatarFrames: {}, avatarErrors: {},  // by participant id: camera avatar frames decoded, errors
  warnings: [], colorFrames: 0,  // decoder warnings (recovered); frame sets with color decoded
  // Pointing and drawing: the others' pointers as last held (by id), the session's annotations,
  // the pointer messages this page sent (the last 128, with the site frame set drawn then), the
  // strokes and labels it sent, and where another's pointer dot was last drawn (the pixel of its
  // hit in the first view, from the bottom left, and the colour read back there).
  drawing: {pointers: {}, held: [], annotations: [], sent: [], pointersSent: 0, drawn: [], dot: null},
  // The camera pass: blended or not, by the frame budget (auto) or the fragment; why it stopped.
  blend: {auto: false, on: true, reason: ''},
};
window.volcast = state;
// Tests: time the WebAssembly decoder on the newest frame (worker.js bench); the result lands in
// window.volcast.bench.
window.volcastBench = (runs) => worker.postMessage({type: 'bench', runs});
// Tests: turn the desktop view towards the case's object `i` (as a person would with the mouse).
window.volcastAim = (i) => {
  const c = session.objectPose(i).position;
  const eye = desktopRoomFromHead();
  const roomFromPlayarea_ = roomFromPlayarea();
  const d = [c[0] - eye[12], c[1] - eye[13], c[2] - eye[14]];
  // Into the play area's axes (the transpose of its rotation).
  const p = [0, 1, 2].map((k) => roomFromPlayarea_[4 * k] * d[0] + roomFromPlayarea_[4 * k + 1] * d[1] +
                                 roomFromPlayarea_[4 * k + 2] * d[2]);
  nav.yaw = Math.atan2(-p[0], -p[2]);
  nav.pitch = Math.atan2(p[1], Math.hypot(p[0], p[2]));
};

const canvas = document.getElementById('view');
const overlay = document.getElementById('overlay');
const gl = canvas.getContext('webgl2', {antialias: false, xrCompatible: true,
                                         preserveDrawingBuffer: true});
if (!gl) fail('this browser has no WebGL2');
const renderer = gl ? new Renderer(gl) : null;
let worker = null;
let clockOffsetUs = 0;
let latest = null;  // the newest decoded frame set not yet uploaded
const latestAvatars = new Map();  // participant id -> its newest decoded avatar frame
const AVATAR_RADIUS_M = 0.6;  // the others' camera avatars: their points this near their head
const nowServerUs = () => (performance.timeOrigin + performance.now()) * 1000 + clockOffsetUs;

function fail(what) {
  state.error = what;
  state.phase = 'error';
  overlay.textContent = 'Error: ' + what;
  overlay.className = 'error';
}

const session = new Session((bytes) => worker.postMessage({type: 'send', bytes}, [bytes]),
                            nowServerUs);
state.session = {joined: false, id: 0, others: [], posesSent: 0, roundTripsMs: []};
const panels = new Panels({state, session, voice: () => voice, nowServerUs,
                           pushToTalk: params.get('ptt') === '1'});
session.onchange = (type) => {
  if (type === T.JOINED && voice) {
    if (voice.muted) session.voiceState(true);  // joined muted
    voice.sendState();
  }
  state.session.joined = !!session.joined;
  state.session.id = session.joined ? session.joined.id : 0;
  state.session.error = session.error;
  state.session.others = [...session.others.values()].map((p) => ({
    id: p.id, name: p.name, role: p.role, poses: p.poses, hasBody: !!p.body}));
  state.session.teleports = session.teleports.length;
  state.session.objects = session.objects.map((o) => ({owner: o.owner, sequence: o.sequence,
                                                       position: o.pose.position}));
  state.session.monitor = session.monitor;
  if (type === T.RECORDING_STATE || type === T.JOINED) panels.showRecording();
  if (type === T.POINTER_FROM)
    for (const [id, p] of session.pointers) state.drawing.pointers[id] = p;
  state.drawing.held = [...session.pointers.keys()];
  if (type === T.ANNOTATION || type === T.ERASED || type === T.JOINED)
    state.drawing.annotations = [...session.annotations.values()].map((a) => ({
      id: a.id, author: a.author, tag: a.tag, kind: a.kind, anchor: a.anchor, slice: a.slice,
      points: a.points, text: a.text}));
};

let voice = null;  // Voice, once the stream is welcomed (voice=0: never)
const caseHold = new CaseHold(session, state);  // the case, and the object this page holds
const pointing = new Pointing({gl, renderer, session, state, currentCase: () => caseHold.case,
                               mode: () => headset.mode, monitorQuad: MONITOR_QUAD});

// Desktop navigation inside the play area: position offset, yaw, pitch. Walking and turning go by
// the time a key is held, not by frames, so a slow frame rate walks and turns as far: `keys` maps a
// held key to the time (performance.now(), ms) up to which its hold has been applied, `pending` a
// released key to the held milliseconds not applied yet.
const nav = {x: 0, z: 0, yaw: 0, pitch: -0.1, keys: new Map(), pending: new Map(), dragging: false};
const WALK_M_PER_S = 1.8;
const MAX_FPS = Number(params.get('fps')) > 0 ? Number(params.get('fps')) : 1000;
const TURN_RAD_PER_S = 2.4;

// Seconds `key` was held since the last call (and consumes them).
function heldSeconds(key, now) {
  let ms = nav.pending.get(key) || 0;
  nav.pending.delete(key);
  const since = nav.keys.get(key);
  if (since !== undefined) {
    ms += Math.max(0, now - since);
    nav.keys.set(key, now);
  }
  return ms / 1000;
}

function keyUp(key) {
  const since = nav.keys.get(key);
  if (since === undefined) return;
  nav.pending.set(key, (nav.pending.get(key) || 0) + Math.max(0, performance.now() - since));
  nav.keys.delete(key);
}

function roomFromPlayarea() {
  return session.joined ? M.spotMatrix(session.joined.spot) : M.translation(0, 0, 2);
}

function roomFromSite() {
  if (!session.joined) return M.identity();
  const r = session.joined.roomFromSite;
  return M.multiply(M.translation(...r.t), M.rotationY(r.yaw));
}

function desktopRoomFromHead() {
  const local = M.multiply(M.rotationY(nav.yaw), M.rotationX(nav.pitch));
  if (!session.joined && renderer.cameras.length) {
    // Outside a session: from the first camera, looking where it looks (its +z, y down, is the
    // view's -z, y up), as the native viewer starts.
    const viewFromCamera = M.scale(1, -1, -1);
    const roomFromEye = M.multiply(M.multiply(roomFromSite(), renderer.cameras[0].siteFromCamera),
                                   M.invertRigid(viewFromCamera));
    return M.multiply(roomFromEye, M.multiply(M.translation(nav.x, 0, nav.z), local));
  }
  return M.multiply(roomFromPlayarea(), M.multiply(M.translation(nav.x, EYE_HEIGHT, nav.z), local));
}

// The room's furniture and the others' avatars (room_boxes.js), or none with room=0; in AR the
// real room is seen, so the avatars alone.
function sceneBoxes() {
  if (params.get('room') === '0') return [];
  const furniture = headset.mode === 'immersive-ar' ? [] : furnitureBoxes();
  return avatarBoxes(session, renderer, voice, [...furniture]);
}

// The frame set uploaded last, until a picture of it was presented: {captureUs, readyMs, drawn}.
let shown = null;
function uploadLatest() {
  for (const [id, frame] of latestAvatars) renderer.uploadAvatar(id, frame);
  latestAvatars.clear();
  if (!latest) return;
  renderer.upload(latest);
  shown = {captureUs: latest.captureUs, readyMs: latest.readyMs, drawn: false};
  latest = null;
}

// "Presented": the animation frame after the one that drew a new frame set -- the browser
// composited that picture in between (requestAnimationFrame's time, `now`, in ms).
function notePresented(now) {
  if (!shown || !shown.drawn) return;
  state.presentedMs.push(now - shown.readyMs);
  state.photonMs.push((nowServerUs() - shown.captureUs) / 1000);
  for (const a of [state.presentedMs, state.photonMs])
    if (a.length > 2000) a.shift();
  shown = null;
}

// The others' camera avatars: each camera where its owner's play area stands, its points kept
// within AVATAR_RADIUS_M of the owner's head (as the native remote_avatar_filter).
function avatarDraws() {
  const out = [];
  for (const [id, c] of renderer.avatars) {
    const p = session.others.get(id);
    if (!p || !p.body) continue;
    out.push({id, roomFromCamera: M.multiply(M.spotMatrix(p.spot), c.siteFromCamera),
              keep: [...p.body.head.position, AVATAR_RADIUS_M]});
  }
  return out;
}

// The camera pass's settings from the fragment (the rest: renderer.js CAMERA_DEFAULTS).
const CAMERA_SETTINGS = {
  surface: params.get('surface') === 'splats' ? 'splats' : 'mesh',
  blend: params.get('blend') !== '0',
  weighting: params.get('weights') === 'angle' ? 'angle' : 'reliability',
  balanceColour: params.get('balance') !== '0',
};

// Blending kept by the frame rate unless the fragment says blend=0 or blend=1 (frame_budget.js).
// The display's period: framems=, else 1000/60 on a desktop (at least fps='s interval), an XR
// session's own frame rate in a headset.
Object.assign(state.blend, {auto: !params.has('blend'),
                           on: CAMERA_SETTINGS.blend && !!(renderer && renderer.floatTargets)});
const FRAME_MS = Number(params.get('framems')) > 0 ? Number(params.get('framems')) : 0;
const desktopPeriodMs = () => FRAME_MS || Math.max(1000 / 60, 1000 / MAX_FPS);
const budget = new FrameBudget(desktopPeriodMs());
let budgetFrameAt = 0;
// The display's period the budget assumes (ms): the desktop's, or a headset's while one runs.
function setBudgetPeriod(ms) {
  budget.setPeriod(ms);
  budgetFrameAt = 0;
}
function keepFrameBudget(now) {
  const interval = budgetFrameAt ? now - budgetFrameAt : 0;
  budgetFrameAt = now;
  if (!state.blend.auto) return;
  const blended = CAMERA_SETTINGS.blend && renderer.floatTargets && state.framesDrawn > 0;
  if (budget.add(interval, blended)) {
    CAMERA_SETTINGS.blend = state.blend.on = false;
    state.blend.reason = budget.reason;
    console.warn('volcast: ' + budget.reason);
  }
}

function scene(eye) {
  const s = {roomFromSite: roomFromSite(), avatars: avatarDraws(), boxes: sceneBoxes(),
             lamp: ROOM.lamp, ...CAMERA_SETTINGS, eye,
             hideSite: headset.mode === 'immersive-ar'};
  const c = caseHold.case;
  if (c && session.generation === c.generation && params.get('room') !== '0') {
    s.objects = c.objects.map((o, i) => ({roomFromObject: caseHold.objectMatrix(i)}));
    if (c.monitor && session.monitor && !s.hideSite) {
      renderer.setMonitor(c.monitor, session.monitor, c.generation);
      s.monitorQuad = MONITOR_QUAD;
    }
  }
  return s;
}

function noteDrawn() {
  if (shown) shown.drawn = true;
  if (renderer.cameras.some((c) => c.hasDepth)) {
    ++state.framesDrawn;
    if (state.firstFrameMs === null) state.firstFrameMs = performance.now();
  }
}

// Desktop frames; the headset's come from its own loop (xr.js).
// probe=1: every 5th frame, where another's pointer dot is drawn (pointing.js noteDot; tests).
const PROBE = params.get('probe') === '1';
let desktopFrameAt = -1e9;
const mouse = {x: 0, y: 0};                       // over the canvas, pixels from the top left
const desktopAim = {key: false, drawing: false};  // L held; Shift+drag drawing
let desktopView = null;                           // the last frame's {clipFromRoom, w, h, s}

// N: a label typed by the person, pinned where the mouse points (up to 64 bytes of UTF-8).
function typeLabel() {
  if (!desktopView || !session.joined) return;
  const v = desktopView;
  const hit = renderer.pick(v.clipFromRoom, v.w, v.h, mouse.x, mouse.y, v.s);
  if (!hit) return;
  let text = (window.prompt('Label (pinned where the mouse points):') || '').trim();
  while (new TextEncoder().encode(text).length > 64) text = text.slice(0, -1);
  if (text) pointing.pin(hit, text);
}
function desktopFrame() {
  if (state.xr.active) return;
  requestAnimationFrame(desktopFrame);
  const now = performance.now();
  notePresented(now);
  if (now - desktopFrameAt < 1000 / MAX_FPS - 2) return;  // fps=: a slow machine's share
  desktopFrameAt = now;
  keepFrameBudget(now);
  ++state.desktopFrames;
  const f = [Math.sin(nav.yaw), Math.cos(nav.yaw)];
  const back = (heldSeconds('s', now) - heldSeconds('w', now)) * WALK_M_PER_S;
  const right = (heldSeconds('d', now) - heldSeconds('a', now)) * WALK_M_PER_S;
  nav.x += f[0] * back + f[1] * right;
  nav.z += f[1] * back - f[0] * right;
  const turn = (heldSeconds('x', now) - heldSeconds('z', now)) * TURN_RAD_PER_S;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== w || canvas.height !== h) {
    canvas.width = w;
    canvas.height = h;
  }
  uploadLatest();
  const roomFromHead = desktopRoomFromHead();
  if (caseHold.holding && caseHold.holding.follow === 'head')
    caseHold.moveHeld(roomFromHead, turn);
  const clipFromRoom = M.multiply(M.perspective(70, w / Math.max(h, 1), 0.05, 50),
                                  M.invertRigid(roomFromHead));
  const eye = [roomFromHead[12], roomFromHead[13], roomFromHead[14]];
  const s = scene(eye);
  // The pointer from the right hand (0.15 m right of and 0.25 m below the eye) through the mouse.
  const hand = M.apply(roomFromHead, [0.15, -0.25, -0.1]).slice(0, 3);
  pointing.updateAim(desktopAim.key, desktopAim.drawing, clipFromRoom, w, h, mouse.x, mouse.y, hand,
                     s);
  pointing.eraseDue(now);
  desktopView = {clipFromRoom, w, h, s};
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  gl.clearColor(0.08, 0.09, 0.11, 1);
  gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
  renderer.draw(clipFromRoom, [0, 0, w, h],
                {...pointing.addDrawing(s, eye), viewFromRoom: M.invertRigid(roomFromHead)});
  if (PROBE && state.desktopFrames % 5 === 0) pointing.noteDot(clipFromRoom, [0, 0, w, h]);
  noteDrawn();
  const head = M.toPose(roomFromHead);
  session.publish({handsTracked: false, head, left: head, right: head});
  if (voice) voice.place(head);
  state.session.posesSent = session.posesSent;
  state.session.roundTripsMs = session.roundTripsMs;
  panels.update();
}

// Voice starts with the session: what fails (no microphone, no WebCodecs Opus) is shown, and the
// stream and session go on without it.
function startVoice() {
  if (params.get('voice') === '0' || voice) return;
  const volumes = new Map();
  for (const item of (params.get('volume') || '').split(',').filter((x) => x)) {
    const at = item.lastIndexOf(':');
    if (at > 0) volumes.set(item.slice(0, at), Number(item.slice(at + 1)));
  }
  voice = new Voice(session, worker, nowServerUs, {mic: params.get('mic') !== '0',
                                           muted: params.get('muted') === '1',
                                           pushToTalk: params.get('ptt') === '1', volumes,
                                           processing: params.get('processing') !== '0',
                                           record: Number(params.get('record') || 0)});
  window.volcastHeard = () => voice.heard();
  window.volcastHeardLog = () => voice.heardLog();
  window.volcastCaptured = () => voice.captured();
  voice.start().catch((err) => { voice.error = `${err.name || 'Error'}: ${err.message}`; });
}

function teleportTo(hit, yaw) {
  if (!hit || !session.joined) return;
  session.teleport({x: hit[0], z: hit[1], yaw});
  nav.x = nav.z = 0;
}

function setupInput() {
  canvas.addEventListener('mousedown', (e) => {
    // Shift+drag draws instead of turning, Alt+drag an arrow.
    if (e.shiftKey || e.altKey) desktopAim.drawing = e.altKey ? 'arrow' : 'stroke';
    else nav.dragging = true;
  });
  window.addEventListener('mouseup', () => { nav.dragging = desktopAim.drawing = false; });
  window.addEventListener('mousemove', (e) => {
    const r = canvas.getBoundingClientRect();
    mouse.x = e.clientX - r.left;
    mouse.y = e.clientY - r.top;
    if (!nav.dragging) return;
    nav.yaw -= e.movementX * 0.004;
    nav.pitch = Math.max(-1.4, Math.min(1.4, nav.pitch - e.movementY * 0.004));
  });
  window.addEventListener('keydown', (e) => {
    const key = e.key.toLowerCase();
    if (e.repeat) return;
    if (key === 'g') {
      if (caseHold.holding) caseHold.releaseHeld();
      else caseHold.grabNear(desktopRoomFromHead(), 'head', true);
      return;
    }
    if (caseHold.monitorKey(key)) return;
    if (key === 'l') return void (desktopAim.key = true);
    if (key === 'backspace' || key === 'delete') return pointing.eraseNewest();
    if (key === 'n') return typeLabel();
    if (voice && key === 'm') return voice.setMuted(!voice.muted);
    if (voice && key === 'v') return voice.setTalking(true);
    if (!nav.keys.has(key)) nav.keys.set(key, performance.now());
  });
  window.addEventListener('keyup', (e) => {
    if (voice && e.key.toLowerCase() === 'v') voice.setTalking(false);
    if (e.key.toLowerCase() === 'l') desktopAim.key = false;
    keyUp(e.key.toLowerCase());
  });
  // A key held while the page loses focus never sees its keyup.
  window.addEventListener('blur', () => {
    [...nav.keys.keys()].forEach(keyUp);
    desktopAim.key = desktopAim.drawing = false;
    if (voice) voice.setTalking(false);
  });
  canvas.addEventListener('dblclick', (e) => {
    // The ray through the clicked pixel, from the eye.
    const w = canvas.clientWidth, h = canvas.clientHeight;
    const t = Math.tan((70 * Math.PI) / 360);
    const dir = [((2 * e.offsetX) / w - 1) * t * (w / h), (1 - (2 * e.offsetY) / h) * t, -1];
    const roomFromHead = desktopRoomFromHead();
    const d = [0, 1, 2].map((r) => roomFromHead[r] * dir[0] + roomFromHead[4 + r] * dir[1] +
                                   roomFromHead[8 + r] * dir[2]);
    if (d[1] >= -1e-3) return;
    const k = -roomFromHead[13] / d[1];
    const spotYaw = session.joined ? session.joined.spot.yaw + nav.yaw : nav.yaw;
    teleportTo([roomFromHead[12] + k * d[0], roomFromHead[14] + k * d[2]], spotYaw);
    nav.yaw = 0;
  });
  if (navigator.xr)
    for (const [id, mode, name] of [['enter-vr', 'immersive-vr', 'VR'], ['enter-ar', 'immersive-ar', 'AR']])
      navigator.xr.isSessionSupported(mode).then((ok) => {
        if (!ok) return;
        const button = document.getElementById(id);
        button.hidden = false;
        button.onclick = () => headset.enter(mode).catch((e) => fail(`cannot enter ${name}: ${e.message}`));
      });
}

// A rate such as '20M', '500k' or '2000000' in bits per second (as `volcast view --max-rate`).
function parseRate(text) {
  const m = /^([0-9.]+)([kKmMgG]?)$/.exec(text);
  if (!m) return 0;
  return Number(m[1]) * ({'': 1, k: 1e3, m: 1e6, g: 1e9}[m[2].toLowerCase()]);
}

function start() {
  const token = params.get('token') || '';
  if (!/^[0-9a-fA-F]{32}$/.test(token)) {
    fail('the link has no join token: open the browser link the server printed');
    return;
  }
  const depth = params.get('depth') || 'volcast';
  const color = params.get('color') || 'jpeg';
  const quality = Number(params.get('quality') || 0);
  // As `volcast view`: adapting to the path unless the link pins a codec or quality.
  const adapt = !['depth', 'color', 'quality'].some((k) => params.has(k));
  const floor = params.get('floor') || '';
  const maxRate = parseRate(params.get('maxRate') || '0');
  state.tier = `${depth}/${color}`;
  state.adaptive = adapt;
  worker = new Worker('worker.js');
  worker.onerror = (e) => fail(`the stream worker failed: ${e.message || 'could not load'}`);
  worker.onmessage = (e) => {
    const m = e.data;
    if (m.type === 'welcome' && m.reconnected) {
      clockOffsetUs = m.clockOffsetUs;
      state.connection = '';
      state.outages.push({ms: Math.round(m.outageMs), why: state.cutWhy});
      session.rejoin();
    } else if (m.type === 'welcome') {
      clockOffsetUs = m.clockOffsetUs;
      state.cameras = m.cameras.length;
      state.phase = 'streaming';
      renderer.setCameras(m.cameras.map((c) => ({...c, siteFromCamera: M.rigid(c.rotation, c.translation)})));
      session.list();
      session.join(params.get('session') || 'OR',
                   params.get('name') || `Browser ${Math.floor(Math.random() * 9000 + 1000)}`);
      startVoice();
    } else if (m.type === 'frames') {
      m.readyMs = performance.now();
      if (m.gains) renderer.setGains(m.gains);
      ++state.framesReceived;
      if (m.cameras.some((c) => c.color)) ++state.colorFrames;
      state.decodeMs.push(m.decodeMs);
      state.depthDecodeMs.push(m.depthDecodeMs);
      state.latencyMs.push((nowServerUs() - m.captureUs) / 1000);
      for (const a of [state.decodeMs, state.depthDecodeMs, state.latencyMs])
        if (a.length > 2000) a.shift();
      if (params.get('check') === '1') {
        state.hashes.push({sequence: m.sequence, hashes: m.cameras.map((c) => c.hash)});
        if (state.hashes.length > 2000) state.hashes.shift();
      }
      if (latest) latest.cameras.forEach((c) => c.color && c.color.close());
      latest = m;
    } else if (m.type === 'tier') {
      state.tier = m.quality ? `${m.depth}/${m.color}/${m.quality}` : `${m.depth}/${m.color}`;
      if (m.divisor > 1) state.tier += `@${m.divisor}`;
      state.losslessDepth = !m.depth.startsWith('volcast-n');
      state.pathMbit = m.pathMbit;
      state.tierChanges.push({tier: state.tier, notice: !m.change, pathMbit: m.pathMbit,
                              reason: m.reason});
      if (state.tierChanges.length > 8) state.tierChanges.shift();
      panels.update(true);
    } else if (m.type === 'reconnecting') {
      if (!state.connection) state.cutWhy = m.why;
      state.connection = `reconnecting: ${m.why}`;
      state.reconnecting = (state.reconnecting || 0) + 1;
      panels.update(true);
    } else if (m.type === 'stale') {
      state.framesStale = m.count;
    } else if (m.type === 'avatar-camera') {
      renderer.setAvatarCamera(m.id, {...m.camera, siteFromCamera: M.rigid(m.camera.rotation,
                                                                           m.camera.translation)});
    } else if (m.type === 'avatar') {
      const old = latestAvatars.get(m.id);
      if (old && old.color) old.color.close();
      latestAvatars.set(m.id, m);
      state.avatarFrames[m.id] = (state.avatarFrames[m.id] || 0) + 1;
    } else if (m.type === 'avatar-error') {
      state.avatarErrors[m.id] = m.what;
    } else if (m.type === 'case') {
      caseHold.setCase(m.case);
      session.setCase(m.case);
      renderer.setCase(m.case);
      state.case = {name: m.case.name, generation: m.case.generation,
                    objects: m.case.objects.map((o) => o.name),
                    slices: m.case.monitor ? m.case.monitor.slices : 0};
      session.onchange();
    } else if (m.type === 'bench') {
      state.bench = m.result;
    } else if (m.type === 'session') {
      try {
        session.receive(m.bytes);
      } catch (err) {
        fail(err.message);
      }
      if (voice) voice.follow();
      for (const id of renderer.avatars.keys())
        if (!session.others.has(id)) renderer.removeAvatar(id);
    } else if (m.type === 'voice-speaker-needed') {
      if (voice) voice.addSpeaker(m.id);
    } else if (m.type === 'voice-captured') {
      if (voice?.onCaptured) voice.onCaptured(m.samples);
    } else if (m.type === 'voice-stats') {
      if (voice) {
        voice.stats = m.stats;
        state.voice = voice.summary();
      }
    } else if (m.type === 'warning') {
      state.warnings.push(m.what);
      if (state.warnings.length > 20) state.warnings.shift();
    } else if (m.type === 'error') {
      fail(m.what);
    } else if (m.type === 'closed') {
      if (state.phase !== 'error') fail('the server closed the stream: ' + m.why);
    }
  };
  const scheme = location.protocol === 'https:' ? 'wss:' : 'ws:';
  worker.postMessage({type: 'start', url: `${scheme}//${location.host}/stream`, token, depth,
                      color, quality, adapt, floor, maxRate, check: params.get('check') === '1'});
  setupInput();
  requestAnimationFrame(desktopFrame);
}

const headset = new Headset({
  gl, renderer, session, state, params, pointing, probe: PROBE, frameMs: FRAME_MS,
  voice: () => voice, holding: () => caseHold.holding, roomFromPlayarea, roomFromSite,
  teleportTo, grabNear: (...a) => caseHold.grabNear(...a), moveHeld: (...a) => caseHold.moveHeld(...a),
  releaseHeld: () => caseHold.releaseHeld(), scene, uploadLatest, notePresented, noteDrawn,
  keepFrameBudget, setBudgetPeriod, desktopPeriodMs,
  resumeDesktop: () => requestAnimationFrame(desktopFrame),
});

if (renderer) start();
