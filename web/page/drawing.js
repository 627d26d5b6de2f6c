// What pointing and drawing look like in the page, as the native annotation_scene.cpp draws them
// (src/render/include/volcast/render/annotation_scene.hpp): a participant's laser pointer (a beam
// and a dot facing the eye, 1.5 cm towards it on the line from the eye through the hit) and the
// session's strokes (8 mm tubes), arrows and label pins, in the owner's colour (the native
// participant_color palette), as primitives for Renderer.drawPrimitives: {shape ('box',
// 'cylinder', 'sphere'; unit size: side, height and diameter 1, centred), roomFromShape, color
// [r, g, b, a], emissive (0..1)}. Room frame, metres.
import {multiply, rotationAlong, rotationY, scale, translation} from './math.js';

const GLOW = 0.85;
const PALETTE = [[0.95, 0.55, 0.2], [0.3, 0.7, 0.95], [0.6, 0.85, 0.3], [0.9, 0.35, 0.6],
                 [0.95, 0.85, 0.3], [0.55, 0.45, 0.95]];

// A participant's colour (linear RGB 0..1) by id: its avatar, pointer and drawings.
export function participantColor(id) { return PALETTE[id % PALETTE.length]; }

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const times = (a, k) => [a[0] * k, a[1] * k, a[2] * k];
const norm = (a) => Math.hypot(a[0], a[1], a[2]);

// The unit cylinder (about +y) as a tube of `width` from a to b.
function tube(a, b, width, color) {
  const d = sub(b, a);
  return {shape: 'cylinder', color, emissive: GLOW,
          roomFromShape: multiply(translation(...times(add(a, b), 0.5)),
                                  multiply(rotationAlong(1, d), scale(width, norm(d), width)))};
}

function ball(at, width, color) {
  return {shape: 'sphere', color, emissive: GLOW,
          roomFromShape: multiply(translation(...at), scale(width, width, width))};
}

// A laser pointer from `origin` to `hit` (without a hit: 3 m towards it, no dot) seen from `eye`.
export function pointerPrimitives(origin, hasHit, hit, rgb, eye) {
  const ray = sub(hit, origin);
  if (norm(ray) < 1e-4) return [];
  const dir = times(ray, 1 / norm(ray));
  const beam = [...rgb, 0.6];
  if (!hasHit) return [tube(origin, add(origin, times(dir, 3)), 0.005, beam)];
  const toEye = sub(eye, hit);
  const lift = Math.min(0.015, 0.5 * norm(toEye));
  const facing = norm(toEye) > 1e-4 ? times(toEye, 1 / norm(toEye)) : times(dir, -1);
  const centre = add(hit, times(facing, lift));
  return [tube(origin, hit, 0.005, beam),
          {shape: 'sphere', color: [...rgb, 1], emissive: 1,
           roomFromShape: multiply(translation(...centre),
                                   multiply(rotationAlong(2, facing), scale(0.03, 0.03, 0.004)))}];
}

// Where a label's text goes: the top of its pin's stick.
export function labelAnchor(a) { return add(a.points[0], [0, 0.12, 0]); }

// One annotation ({kind: 0 stroke, 1 arrow, 2 label; points}).
export function annotationPrimitives(a, rgb) {
  const c = [...rgb, 1], p = a.points, out = [];
  if (a.kind === 0) {
    p.forEach((x, i) => {
      out.push(ball(x, 0.008, c));
      if (i > 0 && norm(sub(x, p[i - 1])) > 1e-5) out.push(tube(p[i - 1], x, 0.008, c));
    });
  } else if (a.kind === 1 && p.length === 2 && norm(sub(p[1], p[0])) >= 1e-4) {
    const length = norm(sub(p[1], p[0])), dir = times(sub(p[1], p[0]), 1 / length);
    const head = Math.min(0.06, length), base = sub(p[1], times(dir, head));
    out.push(tube(p[0], base, 0.01, c));
    for (let i = 0; i < 4; ++i)  // the head: four stacked discs narrowing to the point
      out.push(tube(add(base, times(dir, (head * i) / 4)), add(base, times(dir, (head * (i + 1)) / 4)),
                    (0.04 * (4 - i)) / 4, c));
  } else if (a.kind === 2 && p.length === 1) {
    const top = labelAnchor(a), flag = add(top, [0.03, -0.02, 0]);
    out.push(ball(p[0], 0.025, c), tube(p[0], top, 0.006, c),
             {shape: 'box', color: c, emissive: GLOW,
              roomFromShape: multiply(translation(...flag), scale(0.06, 0.04, 0.004))});
  }
  return out;
}

// A label's text as a quad facing `eye` above its pin's flag, 5 cm high: {roomFromQuad (the unit
// quad, -0.5..0.5), text, rgb}.
export function labelQuad(a, rgb, eye, aspect) {
  const at = add(labelAnchor(a), [0, 0.05, 0]);
  const toEye = sub(eye, at);
  toEye[1] = 0;  // upright, turned about the vertical towards the eye
  const yaw = norm(toEye) > 1e-4 ? Math.atan2(toEye[0], toEye[2]) : 0;
  return {text: a.text, rgb,
          roomFromQuad: multiply(translation(...at), multiply(rotationY(yaw), scale(0.05 * aspect, 0.05, 1)))};
}

// A stroke being drawn: hit points kept at least 5 mm apart, at most 256 (annotations.hpp's
// kMaxStrokePoints); sent as one 0x11 once it has 2 or more.
export class StrokeBuilder {
  constructor() { this.points = []; }
  add(p) {
    const last = this.points[this.points.length - 1];
    if (this.points.length >= 256 || (last && norm(sub(p, last)) < 0.005)) return;
    this.points.push(p.map(Math.fround));
  }
}
