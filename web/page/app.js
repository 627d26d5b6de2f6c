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
// In a headset, the right controller's ray: hold A to point, B to draw; its thumbstick pressed
// pins a preset label there (leaning it picks the text: XR_LABELS); the left thumbstick pressed
// erases your newest (as the native headset: hand_pointing.hpp).
// AR (immersive-ar, where the device has it: a headset's passthrough at the site): the real room
// is seen, so the page draws neither the site's clouds nor the virtual room, only the others'
// avatars, pointers and annotations and the case's organs; the headset's local-floor frame is
// taken as the site's world frame (the frame of the cameras' world_from_camera), so room things
// are placed through site_from_room = inverse(room_from_site) of the Joined message; there the
// trigger points too (no teleporting in the real room). docs/usage.md says how to align them.
// window.volcast holds what the page measured, for people (the overlay) and tests.
import * as M from './math.js';
import {EraseLast} from './erase_last.js';
import {FrameBudget} from './frame_budget.js';
import {Renderer, poseBox, roomBox} from './renderer.js';
import {StrokeBuilder, annotationPrimitives, labelQuad, participantColor, pointerPrimitives}
    from './drawing.js';
import {Session, T} from './session.js';
import {Voice} from './voice.js';

const params = new URLSearchParams(location.hash.slice(1));
const EYE_HEIGHT = 1.6;
// The room as src/session/room.cpp's default_operating_room() lays it out (metres, room frame).
const ROOM = {width: 7, depth: 6, height: 3, table: {centre: [0, 0.45, 0], half: [1.0, 0.45, 0.3]},
              lamp: [0, 2.2, 0]};
// The wall monitor and where its image goes (room_scene.cpp monitor_image_quad).
const MONITOR_QUAD = M.multiply(M.translation(-1.45, 1.6, -ROOM.depth / 2 + 0.1), M.scale(0.56, 0.56, 1));
const PRESETS = [['abdomen', 40, 400], ['liver', 90, 150], ['bone', 480, 2500]];  // objects.hpp

const state = {
  phase: 'connecting', error: '', cameras: 0, framesReceived: 0, framesDrawn: 0,
  firstFrameMs: null, decodeMs: [], depthDecodeMs: [], hashes: [], latencyMs: [],
  // The last latency stage, as the native viewer's (stage_stats.hpp): ready (the decoded frame
  // set reached the page) -> presented, and capture -> presented ("photon"), ms.
  presentedMs: [], photonMs: [],
  session: null, xr: {frames: 0, views: 0, active: false}, tier: '', desktopFrames: 0,
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
  if (type === T.RECORDING_STATE || type === T.JOINED) showRecording();
  if (type === T.POINTER_FROM)
    for (const [id, p] of session.pointers) state.drawing.pointers[id] = p;
  state.drawing.held = [...session.pointers.keys()];
  if (type === T.ANNOTATION || type === T.ERASED || type === T.JOINED)
    state.drawing.annotations = [...session.annotations.values()].map((a) => ({
      id: a.id, author: a.author, tag: a.tag, kind: a.kind, anchor: a.anchor, slice: a.slice,
      points: a.points, text: a.text}));
};

// The case: as the worker parsed it, and what this page holds (object index, the frame it follows:
// 'head' or an XR input source, and hand_from_object when it was grabbed).
let currentCase = null;
let voice = null;  // Voice, once the stream is welcomed (voice=0: never)
let holding = null;

function objectMatrix(i) {
  const p = session.objectPose(i);
  return M.fromPose(p.position, p.orientation);
}

// Grabs the object nearest `roomFromHand`'s origin within reach (radius + 0.15 m), or with
// `alongRay` the one the hand's -z ray passes through, nearest first.
function grabNear(roomFromHand, follow, alongRay) {
  if (!currentCase || !session.joined || holding) return;
  const o = [roomFromHand[12], roomFromHand[13], roomFromHand[14]];
  const d = [-roomFromHand[8], -roomFromHand[9], -roomFromHand[10]];
  let best = -1, bestDistance = Infinity;
  currentCase.objects.forEach((obj, i) => {
    const c = session.objectPose(i).position;
    const v = [c[0] - o[0], c[1] - o[1], c[2] - o[2]];
    let distance;
    if (alongRay) {
      const t = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
      const miss = Math.hypot(v[0] - t * d[0], v[1] - t * d[1], v[2] - t * d[2]);
      distance = t > 0 && miss <= obj.radius + 0.05 ? t : Infinity;
    } else {
      distance = Math.hypot(...v) <= obj.radius + 0.15 ? Math.hypot(...v) : Infinity;
    }
    if (distance < bestDistance) best = i, bestDistance = distance;
  });
  if (best < 0) return;
  session.grab(best);
  holding = {object: best, follow, handFromObject: M.multiply(M.invertRigid(roomFromHand), objectMatrix(best))};
}

// Moves the held object with its hand (once the server made us its owner).
function moveHeld(roomFromHand, turn = 0) {
  if (!holding) return;
  const o = session.objects[holding.object];
  if (!o || !session.joined || o.owner !== session.joined.id) return;
  if (turn) {
    holding.handFromObject = M.multiply(holding.handFromObject, M.rotationY(turn));
    if (state.case) state.case.turnedRad = (state.case.turnedRad || 0) + turn;  // for tests
  }
  session.move(holding.object, M.toPose(M.multiply(roomFromHand, holding.handFromObject)));
}

function releaseHeld() {
  if (!holding) return;
  const o = session.objects[holding.object];
  if (o && session.joined && o.owner === session.joined.id) session.release(holding.object, o.pose);
  holding = null;
}

function monitorKey(key) {
  if (!currentCase || !currentCase.monitor || !session.monitor) return false;
  const m = {...session.monitor};
  const slices = currentCase.monitor.slices;
  if (key === '[') m.slice = Math.max(0, m.slice - 1);
  else if (key === ']') m.slice = Math.min(slices - 1, m.slice + 1);
  else if (key === 'o') m.overlay = !m.overlay;
  else if (['1', '2', '3'].includes(key)) [, m.center, m.width] = PRESETS[Number(key) - 1];
  else return false;
  session.setMonitor(m);
  return true;
}

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

// The furniture does not move: its boxes are made once.
let roomBoxes = null;

function sceneBoxes() {
  if (params.get('room') === '0') return [];
  if (xrMode === 'immersive-ar') return avatarBoxes([]);  // the real room is seen
  roomBoxes = roomBoxes || [
    roomBox([0, -0.01, 0], [ROOM.width / 2, 0.01, ROOM.depth / 2], [0.55, 0.58, 0.6, 1], true),
    roomBox(ROOM.table.centre, ROOM.table.half, [0.35, 0.45, 0.5, 1]),
    roomBox(ROOM.lamp, [0.25, 0.05, 0.25], [0.9, 0.9, 0.8, 1]),
    roomBox([0, ROOM.height / 2, -ROOM.depth / 2], [ROOM.width / 2, ROOM.height / 2, 0.01],
            [0.42, 0.5, 0.52, 1]),
    roomBox([0, ROOM.height / 2, ROOM.depth / 2], [ROOM.width / 2, ROOM.height / 2, 0.01],
            [0.42, 0.5, 0.52, 1]),
    roomBox([-ROOM.width / 2, ROOM.height / 2, 0], [0.01, ROOM.height / 2, ROOM.depth / 2],
            [0.45, 0.52, 0.55, 1]),
    roomBox([ROOM.width / 2, ROOM.height / 2, 0], [0.01, ROOM.height / 2, ROOM.depth / 2],
            [0.45, 0.52, 0.55, 1]),
    roomBox([-1.2, 1.6, -ROOM.depth / 2 + 0.06], [0.6, 0.35, 0.025], [0.08, 0.09, 0.1, 1]),
  ];
  return avatarBoxes([...roomBoxes]);
}

// The others' avatars (those without a camera avatar), appended to `boxes`.
function avatarBoxes(boxes) {
  for (const p of session.others.values()) {
    if (!p.body || p.role === 1) continue;
    const avatar = renderer.avatars.get(p.id);
    if (avatar && avatar.hasDepth) continue;  // seen as its camera's points
    const c = [...participantColor(p.id), 1];
    boxes.push(poseBox(p.body.head, [0, 0, 0], [0.09, 0.11, 0.1], c));
    boxes.push(poseBox(p.body.head, [0, 0, -0.1], [0.08, 0.04, 0.02], [0.1, 0.1, 0.1, 1]));
    boxes.push(poseBox(p.body.head, [0, -0.45, 0.05], [0.18, 0.3, 0.1], c));
    if (p.muted) boxes.push(poseBox(p.body.head, [0, 0.22, 0], [0.06, 0.06, 0.06], [0.85, 0.15, 0.1, 1]));
    else if (voice && voice.speaking(p.id))  // bright, to stand out from a green avatar
      boxes.push(poseBox(p.body.head, [0, 0.24, 0], [0.05, 0.05, 0.05], [0.55, 1, 0.55, 1]));
    if (p.body.handsTracked)
      for (const h of [p.body.left, p.body.right]) boxes.push(poseBox(h, [0, 0, 0], [0.04, 0.02, 0.08], c));
  }
  return boxes;
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
             hideSite: xrMode === 'immersive-ar'};
  if (currentCase && session.generation === currentCase.generation && params.get('room') !== '0') {
    s.objects = currentCase.objects.map((o, i) => ({roomFromObject: objectMatrix(i)}));
    if (currentCase.monitor && session.monitor && !s.hideSite) {
      renderer.setMonitor(currentCase.monitor, session.monitor, currentCase.generation);
      s.monitorQuad = MONITOR_QUAD;
    }
  }
  return s;
}

// Whether the monitor shows annotation `a`'s slice now (a room annotation always shows).
function monitorShows(a) {
  if (a.anchor !== 1) return true;
  return !!(currentCase && currentCase.monitor && session.monitor && xrMode !== 'immersive-ar' &&
            a.generation === session.generation && a.slice === session.monitor.slice);
}

// Everyone's pointers, the session's annotations and the stroke being drawn, seen from `eye`.
function addDrawing(s, eye) {
  const prims = [], labels = [];
  for (const [id, p] of session.pointers)
    prims.push(...pointerPrimitives(p.origin, p.hasHit, p.hit, participantColor(id), eye));
  const me = session.joined ? session.joined.id : 0, mine = participantColor(me);
  if (aim.on) prims.push(...pointerPrimitives(aim.origin, aim.hasHit, aim.hit, mine, eye));
  for (const a of session.annotations.values()) {
    if (!monitorShows(a)) continue;
    const rgb = participantColor(a.author);
    prims.push(...annotationPrimitives(a, rgb));
    if (a.kind === 2) labels.push(labelQuad(a, rgb, eye, renderer.label(a.text, rgb).aspect));
  }
  if (aim.stroke && aim.stroke.points.length)
    prims.push(...annotationPrimitives(drawnAnnotation(aim.stroke), mine));
  s.primitives = prims;
  s.labels = labels;
  return s;
}

// This page's pointer and the stroke it draws: `aim` holds the ray as last found (origin, hit,
// hasHit: room frame) and whether it is shown (on); `stroke` while drawing.
const aim = {on: false, origin: [0, 0, 0], hit: [0, 0, 0], hasHit: false, stroke: null};

// Aims along the ray through pixel (px, py) of a w x h view drawn through `clipFromRoom`, from
// `origin` (the hand): the hit is where the ray first meets what the page draws (Renderer.pick).
// `pointing`: the pointer is held; `drawing`: a stroke (true or 'stroke') or an arrow ('arrow':
// from where it began to where it ends) is being drawn. Sends the pointer while either is held
// and once more (put away) when both are let go; what was drawn goes out when let go.
function updateAim(pointing, drawing, clipFromRoom, w, h, px, py, origin, s) {
  if (!session.joined) return;
  if (pointing || drawing) {
    const hit = renderer.pick(clipFromRoom, w, h, px, py, s);
    if (hit) {
      aim.hit = hit.map(Math.fround);
    } else {  // no surface: the ray points through a point 3 m along it
      const room = M.invert(clipFromRoom);
      const far = M.apply(room, [(2 * px) / w - 1, 1 - (2 * py) / h, 1]);
      const p = far.slice(0, 3).map((x) => x / far[3]);
      const d = p.map((x, i) => x - origin[i]), n = Math.hypot(...d) || 1;
      aim.hit = origin.map((x, i) => Math.fround(x + (3 * d[i]) / n));
    }
    aim.hasHit = !!hit;
    aim.origin = origin.map(Math.fround);
    aim.on = true;
    session.point(true, aim.origin, aim.hasHit, aim.hit);
    ++state.drawing.pointersSent;
    state.drawing.sent.push({on: true, origin: aim.origin, hasHit: aim.hasHit, hit: aim.hit,
                             sequence: renderer.sequence});
    if (state.drawing.sent.length > 128) state.drawing.sent.shift();
    if (drawing) {
      aim.stroke = aim.stroke || Object.assign(new StrokeBuilder(), {arrow: drawing === 'arrow'});
      if (hit) aim.stroke.add(aim.hit);
    }
  }
  if (!drawing && aim.stroke) {
    const a = drawnAnnotation(aim.stroke);
    aim.stroke = null;
    if (a.points.length >= 2) {
      const tag = session.annotate({...a, ...anchorOf(a.points)});
      eraseLast.sent(tag, performance.now());
      state.drawing.drawn.push({tag, ...a});
    }
  }
  if (!pointing && !drawing && aim.on) putAway();
}

// What a StrokeBuilder drew: a stroke of its points, or an arrow from its first to its last
// (none shorter than 1 cm).
function drawnAnnotation(b) {
  const p = b.points;
  if (!b.arrow) return {kind: 0, points: p};
  const ends = p.length >= 2 ? [p[0], p[p.length - 1]] : [];
  const long = ends.length && Math.hypot(...ends[1].map((x, i) => x - ends[0][i])) >= 0.01;
  return {kind: 1, points: long ? ends : []};
}

// An annotation drawn on the monitor's picture sticks to the CT slice it shows (anchor 1);
// anything else belongs to the room (anchor 0).
function anchorOf(points) {
  if (!currentCase || !currentCase.monitor || !session.monitor || xrMode === 'immersive-ar' ||
      session.generation !== currentCase.generation)
    return {anchor: 0};
  const q = MONITOR_QUAD;  // translation and scale only
  const on = points.every((p) => Math.abs(p[0] - q[12]) <= q[0] / 2 + 0.01 &&
                                 Math.abs(p[1] - q[13]) <= q[5] / 2 + 0.01 && Math.abs(p[2] - q[14]) <= 0.01);
  return on ? {anchor: 1, slice: session.monitor.slice} : {anchor: 0};
}

function putAway() {
  if (!aim.on) return;
  aim.on = false;
  session.point(false, aim.origin, aim.hasHit, aim.hit);
  state.drawing.sent.push({on: false});
  if (state.drawing.sent.length > 128) state.drawing.sent.shift();
}

// Erases this page's newest annotation still in the session, once what it sent before the press
// is back numbered (erase_last.js). A press counts from the end of the frame it came in, after
// what that frame sent (a stroke let go just before it is sent by the frame): eraseDue, called at
// the end of every frame.
const eraseLast = new EraseLast();
let erasePressed = false;
function eraseNewest() {
  erasePressed = true;
}
function eraseDue(now) {
  if (!session.joined) return;
  if (erasePressed) eraseLast.pressed(now);
  erasePressed = false;
  const id = eraseLast.due(session.annotations.values(), session.joined.id, now);
  if (id !== null) session.erase(id);
}

// Records where another's pointer dot is drawn in the bound framebuffer: its hit's pixel in
// `viewport` through `clipFromRoom`, and the colour read back there (probe=1: tests; reading
// back stalls the GPU's pipeline).
const PROBE = params.get('probe') === '1';
function noteDot(clipFromRoom, viewport) {
  for (const [id, p] of session.pointers) {
    if (!p.hasHit) continue;
    const c = M.apply(clipFromRoom, p.hit);
    if (c[3] <= 0) continue;
    const x = Math.floor(viewport[0] + ((c[0] / c[3] + 1) / 2) * viewport[2]);
    const y = Math.floor(viewport[1] + ((c[1] / c[3] + 1) / 2) * viewport[3]);
    if (x < viewport[0] || y < viewport[1] || x >= viewport[0] + viewport[2] || y >= viewport[1] + viewport[3]) continue;
    const rgba = new Uint8Array(4);
    gl.readPixels(x, y, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
    state.drawing.dot = {id, x, y, rgba: [...rgba], hit: p.hit};
    return;
  }
}

function noteDrawn() {
  if (shown) shown.drawn = true;
  if (renderer.cameras.some((c) => c.hasDepth)) {
    ++state.framesDrawn;
    if (state.firstFrameMs === null) state.firstFrameMs = performance.now();
  }
}

// Desktop frames; the headset's come from its own loop (enterXr).
let desktopFrameAt = -1e9;
const mouse = {x: 0, y: 0};                       // over the canvas, pixels from the top left
const desktopAim = {key: false, drawing: false};  // L held; Shift+drag drawing
let desktopView = null;                           // the last frame's {clipFromRoom, w, h, s}

// T: a label typed by the person, pinned where the mouse points (up to 64 bytes of UTF-8).
function typeLabel() {
  if (!desktopView || !session.joined) return;
  const v = desktopView;
  const hit = renderer.pick(v.clipFromRoom, v.w, v.h, mouse.x, mouse.y, v.s);
  if (!hit) return;
  let text = (window.prompt('Label (pinned where the mouse points):') || '').trim();
  while (new TextEncoder().encode(text).length > 64) text = text.slice(0, -1);
  if (!text) return;
  const points = [hit.map(Math.fround)];
  const tag = session.annotate({kind: 2, points, text, ...anchorOf(points)});
  eraseLast.sent(tag, performance.now());
  state.drawing.drawn.push({tag, kind: 2, points, text});
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
  if (holding && holding.follow === 'head')
    moveHeld(roomFromHead, turn);
  const clipFromRoom = M.multiply(M.perspective(70, w / Math.max(h, 1), 0.05, 50),
                                  M.invertRigid(roomFromHead));
  const eye = [roomFromHead[12], roomFromHead[13], roomFromHead[14]];
  const s = scene(eye);
  // The pointer from the right hand (0.15 m right of and 0.25 m below the eye) through the mouse.
  const hand = M.apply(roomFromHead, [0.15, -0.25, -0.1]).slice(0, 3);
  updateAim(desktopAim.key, desktopAim.drawing, clipFromRoom, w, h, mouse.x, mouse.y, hand, s);
  eraseDue(now);
  desktopView = {clipFromRoom, w, h, s};
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  gl.clearColor(0.08, 0.09, 0.11, 1);
  gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
  renderer.draw(clipFromRoom, [0, 0, w, h],
                {...addDrawing(s, eye), viewFromRoom: M.invertRigid(roomFromHead)});
  if (PROBE && state.desktopFrames % 5 === 0) noteDot(clipFromRoom, [0, 0, w, h]);
  noteDrawn();
  const head = M.toPose(roomFromHead);
  session.publish({handsTracked: false, head, left: head, right: head});
  if (voice) voice.place(head);
  state.session.posesSent = session.posesSent;
  state.session.roundTripsMs = session.roundTripsMs;
  updateOverlay();
}

let overlayAt = 0;
function updateOverlay() {
  const now = performance.now();
  if (now - overlayAt < 500 || state.phase === 'error') return;
  overlayAt = now;
  const median = (a) => (a.length ? [...a].sort((x, y) => x - y)[a.length >> 1] : 0);
  const names = [...session.others.values()].map((p) => p.name).join(', ') || 'nobody yet';
  if (state.connection) {
    overlay.textContent = state.connection.toUpperCase().slice(0, 12) + state.connection.slice(12);
    overlay.className = 'reconnecting';
    return;
  }
  overlay.className = '';
  const last = state.tierChanges[state.tierChanges.length - 1];
  overlay.textContent =
      `${state.cameras} camera(s), tier ${state.tier}` +
      `${state.losslessDepth ? '' : ' (LOSSY DEPTH)'}${state.adaptive ? ' adaptive' : ' pinned'}` +
      (state.pathMbit ? ` · path ~${state.pathMbit.toFixed(1)} Mbit/s` : '') +
      (last ? ` · ${last.notice ? 'kept' : '→'} ${last.tier}: ${last.reason}` : '') +
      (state.outages.length ? ` · reconnected ${state.outages.length}×` : '') +
      ` · ${state.framesReceived} frame sets · ` +
      `decode ${median(state.decodeMs).toFixed(1)} ms · ` +
      (state.photonMs.length ? `to photon ${median(state.photonMs).toFixed(0)} ms · ` : '') +
      (session.joined ? `in '${session.joined.name}' with ${names}` : 'joining…') +
      (session.error ? ` · ${session.error}` : '') +
      (state.blend.reason ? ` · ${state.blend.reason}` : '') + voiceLine();
  updatePeople();
}

// Whether the room is being recorded (top centre, never silently): who records and since when.
// (Not yet in a headset's view: issue 53.)
const recordingBadge = document.getElementById('recording');
function showRecording() {
  const r = session.recording;
  state.session.recording = {...r};
  recordingBadge.hidden = !r.recording;
  if (!r.recording) return;
  const since = new Date((r.sinceUs - nowServerUs() + Date.now() * 1000) / 1000);
  recordingBadge.textContent = `REC · recorded by ${r.by}, since ` +
      since.toLocaleTimeString([], {hour: '2-digit', minute: '2-digit'});
}

// The people panel (top right): each other participant with its voice's state (green: speaking,
// red: muted) and a volume slider (0-400 %, as the desktop panel's) that sets the gain their
// voice plays at here.
const people = document.getElementById('people');
const peopleRows = new Map();  // participant id -> {label, slider, value}
function updatePeople() {
  if (!voice || !voice.ctx) return;
  const present = new Set();
  for (const p of session.others.values()) {
    present.add(p.id);
    let row = peopleRows.get(p.id);
    if (!row) {
      const label = document.createElement('span');
      const slider = document.createElement('input');
      Object.assign(slider, {type: 'range', min: '0', max: '4', step: '0.05'});
      slider.dataset.name = p.name;
      slider.setAttribute('aria-label', `volume of ${p.name}`);
      const value = document.createElement('span');
      slider.addEventListener('input', () => {
        voice.setVolume(p.id, Number(slider.value));
        value.textContent = `${Math.round(slider.value * 100)}%`;
      });
      row = {label, slider, value};
      people.append(label, slider, value);
      peopleRows.set(p.id, row);
    }
    const gain = voice.volume(p.id, p.name);
    if (document.activeElement !== row.slider) {
      row.slider.value = String(gain);
      row.value.textContent = `${Math.round(gain * 100)}%`;
    }
    row.label.textContent = p.name + (p.muted ? ' (muted)' : '');
    row.label.className = p.muted ? 'muted' : voice.speaking(p.id) ? 'speaking' : '';
  }
  for (const [id, row] of peopleRows) {
    if (present.has(id)) continue;
    row.label.remove();
    row.slider.remove();
    row.value.remove();
    peopleRows.delete(id);
  }
  people.hidden = peopleRows.size === 0;
}

// The overlay's voice part: the microphone's state and who speaks.
function voiceLine() {
  if (!voice) return '';
  if (!state.voice) return '';
  if (state.voice.error) return ` · voice: ${state.voice.error}`;
  const mic = !state.voice.mic ? 'listening' : state.voice.muted ? 'muted (M)' :
      params.get('ptt') === '1' ? (state.voice.talking ? 'talking' : 'hold V to talk') : 'mic on (M mutes)';
  const speaking = [...session.others.values()].filter((p) => voice.speaking(p.id)).map((p) => p.name);
  return ` · ${mic}` + (speaking.length ? ` · speaking: ${speaking.join(', ')}` : '');
}

// The headset's voice buttons (WebXR's xr-standard gamepad): the left controller's X (button 4)
// held talks with ptt=1; its Y (button 5) pressed mutes and unmutes.
let muteButtonDown = false;
function voiceButtons(sources) {
  for (const source of sources) {
    if (source.handedness !== 'left' || !source.gamepad) continue;
    const b = source.gamepad.buttons;
    voice.setTalking(!!b[4]?.pressed);
    const down = !!b[5]?.pressed;
    if (down && !muteButtonDown) voice.setMuted(!voice.muted);
    muteButtonDown = down;
  }
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

function floorHit(roomFromRay) {
  // The ray's origin and its -z direction, in the room; where it meets y = 0.
  const o = [roomFromRay[12], roomFromRay[13], roomFromRay[14]];
  const d = [-roomFromRay[8], -roomFromRay[9], -roomFromRay[10]];
  if (d[1] > -1e-3) return null;
  const t = -o[1] / d[1];
  return [o[0] + t * d[0], o[2] + t * d[2]];
}

function teleportTo(hit, yaw) {
  if (!hit || !session.joined) return;
  session.teleport({x: hit[0], z: hit[1], yaw});
  nav.x = nav.z = 0;
}

// The headset's pointer and drawing (WebXR's xr-standard gamepad): the right controller's ray;
// A (button 4) held points, B (5) held draws, the thumbstick (3) pressed pins a label where the
// ray meets a surface, its text chosen by where the stick leans then (XR_LABELS); in AR the
// trigger (0) points too. The left thumbstick pressed erases this page's newest annotation. The
// native headset maps them alike (src/pipeline/include/volcast/pipeline/hand_pointing.hpp).
const XR_PICK = M.perspective(60, 1, 0.05, 50);  // a virtual 1001 x 1001 view along the ray
const XR_LABELS = {centre: 'here', up: 'cut here', right: 'careful', down: 'not here', left: 'look'};
let eraseButtonDown = false, labelButtonDown = false;

// The preset a thumbstick (axes 2, 3 of xr-standard) leans to.
function leanedLabel(axes) {
  const x = axes[2] || 0, y = axes[3] || 0;
  if (Math.hypot(x, y) < 0.5) return XR_LABELS.centre;
  if (Math.abs(x) > Math.abs(y)) return x > 0 ? XR_LABELS.right : XR_LABELS.left;
  return y < 0 ? XR_LABELS.up : XR_LABELS.down;  // pushed forward reads negative
}

function xrAim(frame, space, playarea, s) {
  let pointing = false, drawing = false, roomFromRay = null, label = null;
  for (const source of frame.session.inputSources) {
    if (source.handedness === 'left' && source.gamepad) {
      const erase = !!source.gamepad.buttons[3]?.pressed;
      if (erase && !eraseButtonDown) eraseNewest();
      eraseButtonDown = erase;
    }
    if (source.handedness !== 'right' || !source.gamepad || !source.targetRaySpace) continue;
    const b = source.gamepad.buttons;
    pointing = !!b[4]?.pressed || (xrMode === 'immersive-ar' && !!b[0]?.pressed);
    drawing = !!b[5]?.pressed;
    const down = !!b[3]?.pressed;
    if (down && !labelButtonDown) label = leanedLabel(source.gamepad.axes);
    labelButtonDown = down;
    const p = frame.getPose(source.targetRaySpace, space);
    if (p) roomFromRay = M.multiply(playarea, new Float32Array(p.transform.matrix));
  }
  if (!roomFromRay) return updateAim(false, false);
  const clip = M.multiply(XR_PICK, M.invertRigid(roomFromRay));
  if (label && session.joined) {
    const hit = renderer.pick(clip, 1001, 1001, 500.5, 500.5, s);
    if (hit) {
      const points = [hit.map(Math.fround)];
      const tag = session.annotate({kind: 2, points, text: label, ...anchorOf(points)});
      eraseLast.sent(tag, performance.now());
      state.drawing.drawn.push({tag, kind: 2, points, text: label});
    }
  }
  updateAim(pointing, drawing, clip, 1001, 1001, 500.5, 500.5,
            [roomFromRay[12], roomFromRay[13], roomFromRay[14]], s);
}

// `mode`: 'immersive-vr' or 'immersive-ar'.
let xrMode = '';
async function enterXr(mode) {
  const xr = await navigator.xr.requestSession(mode, {optionalFeatures: ['local-floor']});
  xrMode = mode;
  state.xr.mode = mode;
  const ar = mode === 'immersive-ar';
  await gl.makeXRCompatible();
  const scale = Math.min(2, Math.max(0.1, Number(params.get('xrscale') || 1)));
  const layer = new XRWebGLLayer(xr, gl, {framebufferScaleFactor: scale, antialias: false});
  xr.updateRenderState({baseLayer: layer});
  let space;
  try {
    space = await xr.requestReferenceSpace('local-floor');
  } catch {
    space = await xr.requestReferenceSpace('local');
  }
  state.xr.active = true;
  xr.addEventListener('select', (ev) => {
    if (!ev.inputSource.targetRaySpace || ar) return;  // AR: no teleporting in the real room
    const p = ev.frame.getPose(ev.inputSource.targetRaySpace, space);
    if (!p) return;
    const roomFromRay = M.multiply(roomFromPlayarea(), new Float32Array(p.transform.matrix));
    teleportTo(floorHit(roomFromRay), session.joined ? session.joined.spot.yaw : 0);
  });
  const gripOf = (ev) => {
    if (!ev.inputSource.gripSpace) return null;
    const p = ev.frame.getPose(ev.inputSource.gripSpace, space);
    return p ? M.multiply(roomFromPlayarea(), new Float32Array(p.transform.matrix)) : null;
  };
  xr.addEventListener('squeezestart', (ev) => {
    const hand = gripOf(ev);
    if (hand) grabNear(hand, ev.inputSource, false);
  });
  xr.addEventListener('squeezeend', (ev) => {
    if (holding && holding.follow === ev.inputSource) releaseHeld();
  });
  budget.setPeriod(FRAME_MS || (xr.frameRate > 0 ? 1000 / xr.frameRate : 1000 / 60));
  budgetFrameAt = 0;
  xr.addEventListener('end', () => {
    state.xr.active = false;
    xrMode = '';
    budget.setPeriod(desktopPeriodMs());
    budgetFrameAt = 0;
    putAway();
    requestAnimationFrame(desktopFrame);
  });
  const onFrame = (t, frame) => {
    xr.requestAnimationFrame(onFrame);
    notePresented(performance.now());
    keepFrameBudget(t);
    const pose = frame.getViewerPose(space);
    if (!pose) return;
    uploadLatest();
    // AR: the headset's local-floor frame is the site's world frame, so the room is placed
    // through room_from_site; VR: the play area's spot.
    const playarea = ar ? roomFromSite() : roomFromPlayarea();
    if (holding && holding.follow !== 'head' && holding.follow.gripSpace) {
      const g = frame.getPose(holding.follow.gripSpace, space);
      if (g) moveHeld(M.multiply(playarea, new Float32Array(g.transform.matrix)));
    }
    const roomFromEye = M.multiply(playarea, new Float32Array(pose.transform.matrix));
    const eye = [roomFromEye[12], roomFromEye[13], roomFromEye[14]];
    const s = scene(eye);
    xrAim(frame, space, playarea, s);
    eraseDue(performance.now());
    addDrawing(s, eye);
    gl.bindFramebuffer(gl.FRAMEBUFFER, layer.framebuffer);
    if (ar) gl.clearColor(0, 0, 0, 0);  // transparent over the passthrough
    else gl.clearColor(0.08, 0.09, 0.11, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    pose.views.forEach((view, i) => {
      const vp = layer.getViewport(view);
      const roomFromView = M.multiply(playarea, new Float32Array(view.transform.matrix));
      const clipFromRoom = M.multiply(new Float32Array(view.projectionMatrix),
                                      M.invertRigid(roomFromView));
      const viewport = [vp.x, vp.y, vp.width, vp.height];
      renderer.draw(clipFromRoom, viewport, {...s, viewFromRoom: M.invertRigid(roomFromView)});
      if (PROBE && i === 0 && state.xr.frames % 5 === 0) noteDot(clipFromRoom, viewport);
    });
    ++state.xr.frames;
    state.xr.views = pose.views.length;
    noteDrawn();
    const head = M.toPose(M.multiply(playarea, new Float32Array(pose.transform.matrix)));
    const hands = {left: head, right: head};
    let tracked = 0;
    for (const source of frame.session.inputSources) {
      if (!source.gripSpace || (source.handedness !== 'left' && source.handedness !== 'right'))
        continue;
      const g = frame.getPose(source.gripSpace, space);
      if (!g) continue;
      hands[source.handedness] = M.toPose(M.multiply(playarea, new Float32Array(g.transform.matrix)));
      ++tracked;
    }
    session.publish({handsTracked: tracked === 2, head, left: hands.left, right: hands.right});
    if (voice) {
      voice.place(head);
      voiceButtons(frame.session.inputSources);
    }
    state.session.posesSent = session.posesSent;
    state.session.roundTripsMs = session.roundTripsMs;
  };
  xr.requestAnimationFrame(onFrame);
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
      if (holding) releaseHeld();
      else grabNear(desktopRoomFromHead(), 'head', true);
      return;
    }
    if (monitorKey(key)) return;
    if (key === 'l') return void (desktopAim.key = true);
    if (key === 'backspace' || key === 'delete') return eraseNewest();
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
        button.onclick = () => enterXr(mode).catch((e) => fail(`cannot enter ${name}: ${e.message}`));
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
      overlayAt = 0;
      updateOverlay();
    } else if (m.type === 'reconnecting') {
      if (!state.connection) state.cutWhy = m.why;
      state.connection = `reconnecting: ${m.why}`;
      state.reconnecting = (state.reconnecting || 0) + 1;
      overlayAt = 0;
      updateOverlay();
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
      currentCase = m.case;
      holding = null;
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

if (renderer) start();
