// The patient case on the page (session/objects.hpp): the case as the worker parsed it
// (case_wire.js), the organ this page holds -- grabbed with a hand (a headset's grip) or the
// view (the desktop's G), moved with it, let go -- and the wall monitor's keys ([ and ] scroll
// slices, 1/2/3 the abdomen, liver and bone windows, O the overlay). Room frame, metres; the
// server decides who holds what (Session.grab, move, release).
import * as M from './math.js';

const PRESETS = [['abdomen', 40, 400], ['liver', 90, 150], ['bone', 480, 2500]];  // objects.hpp

export class CaseHold {
  // `state`: window.volcast (state.case.turnedRad counts the turns, for tests).
  constructor(session, state) {
    this.session = session;
    this.state = state;
    this.case = null;  // as case_wire.js parsed it
    // {object (index), follow ('head' or an XR input source), handFromObject} while held.
    this.holding = null;
  }

  // A new case: nothing held any more.
  setCase(c) {
    this.case = c;
    this.holding = null;
  }

  // room_from_object of the case's object `i` as the session has it now.
  objectMatrix(i) {
    const p = this.session.objectPose(i);
    return M.fromPose(p.position, p.orientation);
  }

  // Grabs the object nearest `roomFromHand`'s origin within reach (radius + 0.15 m), or with
  // `alongRay` the one the hand's -z ray passes through, nearest first.
  grabNear(roomFromHand, follow, alongRay) {
    const session = this.session;
    if (!this.case || !session.joined || this.holding) return;
    const o = [roomFromHand[12], roomFromHand[13], roomFromHand[14]];
    const d = [-roomFromHand[8], -roomFromHand[9], -roomFromHand[10]];
    let best = -1, bestDistance = Infinity;
    this.case.objects.forEach((obj, i) => {
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
    this.holding = {object: best, follow,
                    handFromObject: M.multiply(M.invertRigid(roomFromHand), this.objectMatrix(best))};
  }

  // Moves the held object with its hand (once the server made us its owner), turned by `turn`
  // radians more about its own y axis.
  moveHeld(roomFromHand, turn = 0) {
    const session = this.session, holding = this.holding;
    if (!holding) return;
    const o = session.objects[holding.object];
    if (!o || !session.joined || o.owner !== session.joined.id) return;
    if (turn) {
      holding.handFromObject = M.multiply(holding.handFromObject, M.rotationY(turn));
      const c = this.state.case;
      if (c) c.turnedRad = (c.turnedRad || 0) + turn;  // for tests
    }
    session.move(holding.object, M.toPose(M.multiply(roomFromHand, holding.handFromObject)));
  }

  // Lets the held object go where it is.
  releaseHeld() {
    const session = this.session, holding = this.holding;
    if (!holding) return;
    const o = session.objects[holding.object];
    if (o && session.joined && o.owner === session.joined.id) session.release(holding.object, o.pose);
    this.holding = null;
  }

  // A monitor key (lower case): whether it was one (and the monitor changed).
  monitorKey(key) {
    const session = this.session, c = this.case;
    if (!c || !c.monitor || !session.monitor) return false;
    const m = {...session.monitor};
    const slices = c.monitor.slices;
    if (key === '[') m.slice = Math.max(0, m.slice - 1);
    else if (key === ']') m.slice = Math.min(slices - 1, m.slice + 1);
    else if (key === 'o') m.overlay = !m.overlay;
    else if (['1', '2', '3'].includes(key)) [, m.center, m.width] = PRESETS[Number(key) - 1];
    else return false;
    session.setMonitor(m);
    return true;
  }
}
