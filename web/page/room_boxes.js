// The virtual OR as boxes for the renderer (renderer.js roomBox, poseBox): the room as
// src/room/room.cpp's default_operating_room() lays it out, and the others' avatars where they have no
// camera avatar (a head, a visor, a torso, hands when tracked; a red box over a muted head, a
// bright green one over a speaking head). Room frame, metres.
import {participantColor} from './drawing.js';
import * as M from './math.js';
import {poseBox, roomBox} from './renderer.js';

// The room's size, table and lamp (metres, room frame).
export const ROOM = {width: 7, depth: 6, height: 3,
                     table: {centre: [0, 0.45, 0], half: [1.0, 0.45, 0.3]}, lamp: [0, 2.2, 0]};
// The wall monitor and where its image goes (room_scene.cpp monitor_image_quad).
export const MONITOR_QUAD = M.multiply(M.translation(-1.45, 1.6, -ROOM.depth / 2 + 0.1), M.scale(0.56, 0.56, 1));

// The furniture does not move: its boxes are made once.
let furniture = null;
export function furnitureBoxes() {
  furniture = furniture || [
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
  return furniture;
}

// While the session is recorded, a red box fixed in a headset's view, where the native headset
// shows its red ball (room_scene.hpp recording_badge_primitives: 0.6 m ahead of the head, 16 cm
// left and 12 cm up, 3 cm): the page's REC badge (panels.js) does not reach an immersive session.
// `roomFromHead`: the viewer's pose (between the eyes), room frame.
export function recordingBadge(roomFromHead) {
  const headFromBox = M.multiply(M.translation(-0.16, 0.12, -0.6), M.scale(0.015, 0.015, 0.015));
  return {roomFromBox: M.multiply(roomFromHead, headFromBox), color: [1, 0.08, 0.06, 1], grid: false};
}

// The others' avatars (those without a camera avatar: Renderer's avatars with depth), appended
// to `boxes`; `voice`: the page's Voice, or null.
export function avatarBoxes(session, renderer, voice, boxes) {
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
