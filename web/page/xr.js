// The page in a headset (WebXR immersive-vr, or immersive-ar where the device has it): its frame
// loop, drawing both eyes and publishing the head and controllers, and its controllers (WebXR's
// xr-standard gamepad), mapped as the native headset's (hand_pointing.hpp): the trigger
// teleports where the ray meets the floor (VR); a grip squeezed near an organ holds it; the right
// controller's ray points while A is held, draws while B is held, and its thumbstick pressed pins
// a preset label (leaning it picks the text: XR_LABELS); in AR the trigger points too; the left
// thumbstick pressed erases this page's newest annotation; the left X held talks (ptt=1), Y mutes.
// AR: the headset's local-floor frame is taken as the site's world frame, so the room is placed
// through room_from_site (app.js roomFromSite); VR: through the play area's spot.
import * as M from './math.js';
import {recordingBadge} from './room_boxes.js';

const XR_PICK = M.perspective(60, 1, 0.05, 50);  // a virtual 1001 x 1001 view along the ray
export const XR_LABELS = {centre: 'here', up: 'cut here', right: 'careful', down: 'not here',
                          left: 'look'};

// The preset a thumbstick (axes 2, 3 of xr-standard) leans to.
function leanedLabel(axes) {
  const x = axes[2] || 0, y = axes[3] || 0;
  if (Math.hypot(x, y) < 0.5) return XR_LABELS.centre;
  if (Math.abs(x) > Math.abs(y)) return x > 0 ? XR_LABELS.right : XR_LABELS.left;
  return y < 0 ? XR_LABELS.up : XR_LABELS.down;  // pushed forward reads negative
}

// Where the ray `roomFromRay` (its origin, along its -z) meets the floor (y = 0): [x, z] or null.
function floorHit(roomFromRay) {
  const o = [roomFromRay[12], roomFromRay[13], roomFromRay[14]];
  const d = [-roomFromRay[8], -roomFromRay[9], -roomFromRay[10]];
  if (d[1] > -1e-3) return null;
  const t = -o[1] / d[1];
  return [o[0] + t * d[0], o[2] + t * d[2]];
}

export class Headset {
  // `page`: what the frame loop uses of app.js -- gl, renderer, session, state, params, probe,
  // voice() and holding() (the current ones), and the page's steps (roomFromPlayarea,
  // roomFromSite, teleportTo, grabNear, moveHeld, releaseHeld, scene, uploadLatest,
  // notePresented, noteDrawn, keepFrameBudget, setBudgetPeriod, desktopPeriodMs, frameMs,
  // resumeDesktop) and its pointing (pointing.js: updateAim, putAway, eraseNewest, eraseDue,
  // label, addDrawing, noteDot).
  constructor(page) {
    this.page = page;
    this.mode = '';  // 'immersive-vr', 'immersive-ar' or '' (the desktop)
    this.muteButtonDown = false;
    this.eraseButtonDown = false;
    this.labelButtonDown = false;
  }

  // The left controller's X (button 4) held talks with ptt=1; its Y (button 5) pressed mutes.
  voiceButtons(voice, sources) {
    for (const source of sources) {
      if (source.handedness !== 'left' || !source.gamepad) continue;
      const b = source.gamepad.buttons;
      voice.setTalking(!!b[4]?.pressed);
      const down = !!b[5]?.pressed;
      if (down && !this.muteButtonDown) voice.setMuted(!voice.muted);
      this.muteButtonDown = down;
    }
  }

  // This frame's pointing from the controllers (`playarea`: room_from_playarea or room_from_site).
  aim(frame, space, playarea, s) {
    const p = this.page.pointing;
    let pointing = false, drawing = false, roomFromRay = null, label = null;
    for (const source of frame.session.inputSources) {
      if (source.handedness === 'left' && source.gamepad) {
        const erase = !!source.gamepad.buttons[3]?.pressed;
        if (erase && !this.eraseButtonDown) p.eraseNewest();
        this.eraseButtonDown = erase;
      }
      if (source.handedness !== 'right' || !source.gamepad || !source.targetRaySpace) continue;
      const b = source.gamepad.buttons;
      pointing = !!b[4]?.pressed || (this.mode === 'immersive-ar' && !!b[0]?.pressed);
      drawing = !!b[5]?.pressed;
      const down = !!b[3]?.pressed;
      if (down && !this.labelButtonDown) label = leanedLabel(source.gamepad.axes);
      this.labelButtonDown = down;
      const pose = frame.getPose(source.targetRaySpace, space);
      if (pose) roomFromRay = M.multiply(playarea, new Float32Array(pose.transform.matrix));
    }
    if (!roomFromRay) return p.updateAim(false, false);
    const clip = M.multiply(XR_PICK, M.invertRigid(roomFromRay));
    if (label) p.label(clip, 1001, 1001, 500.5, 500.5, s, label);
    p.updateAim(pointing, drawing, clip, 1001, 1001, 500.5, 500.5,
                [roomFromRay[12], roomFromRay[13], roomFromRay[14]], s);
  }

  // Enters `mode` ('immersive-vr' or 'immersive-ar') and runs its frame loop until it ends.
  async enter(mode) {
    const page = this.page, {gl, renderer, session, state} = page;
    const xr = await navigator.xr.requestSession(mode, {optionalFeatures: ['local-floor']});
    this.mode = mode;
    state.xr.mode = mode;
    const ar = mode === 'immersive-ar';
    await gl.makeXRCompatible();
    const scale = Math.min(2, Math.max(0.1, Number(page.params.get('xrscale') || 1)));
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
      const roomFromRay = M.multiply(page.roomFromPlayarea(), new Float32Array(p.transform.matrix));
      page.teleportTo(floorHit(roomFromRay), session.joined ? session.joined.spot.yaw : 0);
    });
    const gripOf = (ev) => {
      if (!ev.inputSource.gripSpace) return null;
      const p = ev.frame.getPose(ev.inputSource.gripSpace, space);
      return p ? M.multiply(page.roomFromPlayarea(), new Float32Array(p.transform.matrix)) : null;
    };
    xr.addEventListener('squeezestart', (ev) => {
      const hand = gripOf(ev);
      if (hand) page.grabNear(hand, ev.inputSource, false);
    });
    xr.addEventListener('squeezeend', (ev) => {
      const holding = page.holding();
      if (holding && holding.follow === ev.inputSource) page.releaseHeld();
    });
    page.setBudgetPeriod(page.frameMs || (xr.frameRate > 0 ? 1000 / xr.frameRate : 1000 / 60));
    xr.addEventListener('end', () => {
      state.xr.active = false;
      this.mode = '';
      page.setBudgetPeriod(page.desktopPeriodMs());
      page.pointing.putAway();
      page.resumeDesktop();
    });
    const onFrame = (t, frame) => {
      xr.requestAnimationFrame(onFrame);
      page.notePresented(performance.now());
      page.keepFrameBudget(t);
      const pose = frame.getViewerPose(space);
      if (!pose) return;
      page.uploadLatest();
      const playarea = ar ? page.roomFromSite() : page.roomFromPlayarea();
      const holding = page.holding();
      if (holding && holding.follow !== 'head' && holding.follow.gripSpace) {
        const g = frame.getPose(holding.follow.gripSpace, space);
        if (g) page.moveHeld(M.multiply(playarea, new Float32Array(g.transform.matrix)));
      }
      const roomFromEye = M.multiply(playarea, new Float32Array(pose.transform.matrix));
      const eye = [roomFromEye[12], roomFromEye[13], roomFromEye[14]];
      const s = page.scene(eye);
      if (session.recording.recording) {  // in sight while the room is recorded (issue 53)
        s.boxes = [...s.boxes, recordingBadge(roomFromEye)];
        ++state.xr.recordingBadgeFrames;
      }
      this.aim(frame, space, playarea, s);
      page.pointing.eraseDue(performance.now());
      page.pointing.addDrawing(s, eye);
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
        if (page.probe && i === 0 && state.xr.frames % 5 === 0)
          page.pointing.noteDot(clipFromRoom, viewport);
      });
      ++state.xr.frames;
      state.xr.views = pose.views.length;
      page.noteDrawn();
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
      const voice = page.voice();
      if (voice) {
        voice.place(head);
        this.voiceButtons(voice, frame.session.inputSources);
      }
      state.session.posesSent = session.posesSent;
      state.session.roundTripsMs = session.roundTripsMs;
    };
    xr.requestAnimationFrame(onFrame);
  }
}
