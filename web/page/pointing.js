// This page's pointing and drawing (session/annotations.hpp; drawing.js): its laser pointer
// while held, the stroke or arrow it draws, labels it pins, "erase my last" (erase_last.js), and
// everyone's pointers and the session's annotations as primitives and label quads for the
// renderer. The desktop (app.js) and the headset (xr.js) aim it alike: a ray through a pixel of
// a view, meeting what the page draws (Renderer.pick). Room frame, metres.
import {EraseLast} from './erase_last.js';
import {StrokeBuilder, annotationPrimitives, labelQuad, participantColor, pointerPrimitives}
    from './drawing.js';
import * as M from './math.js';

// What a StrokeBuilder drew: a stroke of its points, or an arrow from its first to its last
// (none shorter than 1 cm).
function drawnAnnotation(b) {
  const p = b.points;
  if (!b.arrow) return {kind: 0, points: p};
  const ends = p.length >= 2 ? [p[0], p[p.length - 1]] : [];
  const long = ends.length && Math.hypot(...ends[1].map((x, i) => x - ends[0][i])) >= 0.01;
  return {kind: 1, points: long ? ends : []};
}

export class Pointing {
  // `currentCase()`: the patient case the page holds (or null); `mode()`: the headset's mode
  // ('' on the desktop, 'immersive-ar' over the passthrough); `monitorQuad`: room_from_quad of
  // the wall monitor's picture (translation and scale only).
  constructor({gl, renderer, session, state, currentCase, mode, monitorQuad}) {
    Object.assign(this, {gl, renderer, session, state, currentCase, mode, monitorQuad});
    // The ray as last found (origin, hit, hasHit) and whether it is shown (on); `stroke` while
    // drawing.
    this.aim = {on: false, origin: [0, 0, 0], hit: [0, 0, 0], hasHit: false, stroke: null};
    this.eraseLast = new EraseLast();
    this.erasePressed = false;
  }

  // Whether the monitor shows annotation `a`'s slice now (a room annotation always shows).
  monitorShows(a) {
    if (a.anchor !== 1) return true;
    const c = this.currentCase(), session = this.session;
    return !!(c && c.monitor && session.monitor && this.mode() !== 'immersive-ar' &&
              a.generation === session.generation && a.slice === session.monitor.slice);
  }

  // Everyone's pointers, the session's annotations and the stroke being drawn, seen from `eye`,
  // into the scene `s` (its primitives and labels).
  addDrawing(s, eye) {
    const session = this.session, aim = this.aim, prims = [], labels = [];
    for (const [id, p] of session.pointers)
      prims.push(...pointerPrimitives(p.origin, p.hasHit, p.hit, participantColor(id), eye));
    const me = session.joined ? session.joined.id : 0, mine = participantColor(me);
    if (aim.on) prims.push(...pointerPrimitives(aim.origin, aim.hasHit, aim.hit, mine, eye));
    for (const a of session.annotations.values()) {
      if (!this.monitorShows(a)) continue;
      const rgb = participantColor(a.author);
      prims.push(...annotationPrimitives(a, rgb));
      if (a.kind === 2) labels.push(labelQuad(a, rgb, eye, this.renderer.label(a.text, rgb).aspect));
    }
    if (aim.stroke && aim.stroke.points.length)
      prims.push(...annotationPrimitives(drawnAnnotation(aim.stroke), mine));
    s.primitives = prims;
    s.labels = labels;
    return s;
  }

  // Aims along the ray through pixel (px, py) of a w x h view drawn through `clipFromRoom`, from
  // `origin` (the hand): the hit is where the ray first meets what the page draws. `pointing`:
  // the pointer is held; `drawing`: a stroke (true or 'stroke') or an arrow ('arrow': from where
  // it began to where it ends) is being drawn. Sends the pointer while either is held and once
  // more (put away) when both are let go; what was drawn goes out when let go.
  updateAim(pointing, drawing, clipFromRoom, w, h, px, py, origin, s) {
    const session = this.session, state = this.state, aim = this.aim;
    if (!session.joined) return;
    if (pointing || drawing) {
      const hit = this.renderer.pick(clipFromRoom, w, h, px, py, s);
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
                               sequence: this.renderer.sequence});
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
        const tag = session.annotate({...a, ...this.anchorOf(a.points)});
        this.eraseLast.sent(tag, performance.now());
        state.drawing.drawn.push({tag, ...a});
      }
    }
    if (!pointing && !drawing && aim.on) this.putAway();
  }

  // Pins a label `text` where the ray through pixel (px, py) of that view meets a surface, if it
  // meets one.
  label(clipFromRoom, w, h, px, py, s, text) {
    if (!this.session.joined) return;
    const hit = this.renderer.pick(clipFromRoom, w, h, px, py, s);
    if (hit) this.pin(hit, text);
  }

  // Sends a label `text` pinned at `hit` (room frame).
  pin(hit, text) {
    const points = [hit.map(Math.fround)];
    const tag = this.session.annotate({kind: 2, points, text, ...this.anchorOf(points)});
    this.eraseLast.sent(tag, performance.now());
    this.state.drawing.drawn.push({tag, kind: 2, points, text});
  }

  // An annotation drawn on the monitor's picture sticks to the CT slice it shows (anchor 1);
  // anything else belongs to the room (anchor 0).
  anchorOf(points) {
    const c = this.currentCase(), session = this.session;
    if (!c || !c.monitor || !session.monitor || this.mode() === 'immersive-ar' ||
        session.generation !== c.generation)
      return {anchor: 0};
    const q = this.monitorQuad;
    const on = points.every((p) => Math.abs(p[0] - q[12]) <= q[0] / 2 + 0.01 &&
                                   Math.abs(p[1] - q[13]) <= q[5] / 2 + 0.01 &&
                                   Math.abs(p[2] - q[14]) <= 0.01);
    return on ? {anchor: 1, slice: session.monitor.slice} : {anchor: 0};
  }

  // The pointer put away (sent once, off).
  putAway() {
    const aim = this.aim, state = this.state;
    if (!aim.on) return;
    aim.on = false;
    this.session.point(false, aim.origin, aim.hasHit, aim.hit);
    state.drawing.sent.push({on: false});
    if (state.drawing.sent.length > 128) state.drawing.sent.shift();
  }

  // Erases this page's newest annotation still in the session, once what it sent before the
  // press is back numbered (erase_last.js). A press counts from the end of the frame it came in,
  // after what that frame sent (a stroke let go just before it is sent by the frame): eraseDue,
  // called at the end of every frame.
  eraseNewest() {
    this.erasePressed = true;
  }
  eraseDue(now) {
    const session = this.session;
    if (!session.joined) return;
    if (this.erasePressed) this.eraseLast.pressed(now);
    this.erasePressed = false;
    const id = this.eraseLast.due(session.annotations.values(), session.joined.id, now);
    if (id !== null) session.erase(id);
  }

  // Records where another's pointer dot is drawn in the bound framebuffer: its hit's pixel in
  // `viewport` through `clipFromRoom`, and the colour read back there (probe=1: tests; reading
  // back stalls the GPU's pipeline).
  noteDot(clipFromRoom, viewport) {
    const gl = this.gl;
    for (const [id, p] of this.session.pointers) {
      if (!p.hasHit) continue;
      const c = M.apply(clipFromRoom, p.hit);
      if (c[3] <= 0) continue;
      const x = Math.floor(viewport[0] + ((c[0] / c[3] + 1) / 2) * viewport[2]);
      const y = Math.floor(viewport[1] + ((c[1] / c[3] + 1) / 2) * viewport[3]);
      if (x < viewport[0] || y < viewport[1] || x >= viewport[0] + viewport[2] ||
          y >= viewport[1] + viewport[3])
        continue;
      const rgba = new Uint8Array(4);
      gl.readPixels(x, y, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
      this.state.drawing.dot = {id, x, y, rgba: [...rgba], hit: p.hit};
      return;
    }
  }
}
