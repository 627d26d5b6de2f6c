// Colour balance in the stream worker (worker.js loads it with importScripts and calls these with
// its WebAssembly module `wasm` and the Welcome's `cameras` set): the native renderer's
// (volcast/render/colour_balance.hpp) compiled into volcast_decoder.wasm. Every BALANCE_EVERY new
// depth images, the newest frame set's samples of each camera with colour (its picture read back
// through a canvas), then every camera's RGB gain, sent with that set. Throws Error("colour
// balance: ...") with the module's reason.
'use strict';

const BALANCE_EVERY = 15;  // as the native CameraRenderer's kUploadsPerBalance
let balanceCountdown = BALANCE_EVERY;
let balanceCanvas = null;
const balanceScratch = {pixels: 0, depth: 0, rgba: 0, gains: 0};

// Gives the module the cameras of the Welcome (intrinsics, world_from_camera) and starts the count.
function setBalanceCameras() {
  const k = wasm._malloc(17 * 8), pose = wasm._malloc(12 * 8);
  cameras.forEach((cam, i) => {
    wasm.HEAPF64.set([cam.width, cam.height, ...cam.intrinsics], k / 8);
    wasm.HEAPF64.set([...cam.rotation, ...cam.translation], pose / 8);
    if (wasm._vc_balance_camera(i, k, pose) !== 0)
      throw new Error('colour balance: ' + wasm.UTF8ToString(wasm._vc_last_error()));
  });
  wasm._free(k);
  wasm._free(pose);
  balanceCountdown = BALANCE_EVERY;
}

// The gains from this frame set's depth images and pictures (cameras without either keep their
// last samples), or null when no camera had both.
function balanceGains(out, bitmaps) {
  const s = balanceScratch;
  let taken = 0;
  out.forEach((f, c) => {
    const b = bitmaps[c];
    if (!f.depth || !b || b.width !== f.width || b.height !== f.height) return;
    const n = f.width * f.height;
    if (n > s.pixels) {
      for (const p of [s.depth, s.rgba]) if (p) wasm._free(p);
      s.pixels = n;
      s.depth = wasm._malloc(n * 2);
      s.rgba = wasm._malloc(n * 4);
    }
    if (!balanceCanvas || balanceCanvas.width !== f.width || balanceCanvas.height !== f.height)
      balanceCanvas = new OffscreenCanvas(f.width, f.height);
    const ctx = balanceCanvas.getContext('2d', {willReadFrequently: true});
    ctx.drawImage(b, 0, 0);
    wasm.HEAPU8.set(ctx.getImageData(0, 0, f.width, f.height).data, s.rgba);
    wasm.HEAPU16.set(f.depth, s.depth / 2);
    if (wasm._vc_balance_take(c, s.depth, s.rgba) < 0)
      throw new Error('colour balance: ' + wasm.UTF8ToString(wasm._vc_last_error()));
    ++taken;
  });
  if (!taken) return null;
  if (!s.gains) s.gains = wasm._malloc(64 * 3 * 4);
  if (wasm._vc_balance_gains(out.length, s.gains) !== 0)
    throw new Error('colour balance: ' + wasm.UTF8ToString(wasm._vc_last_error()));
  const g = wasm.HEAPF32.subarray(s.gains / 4, s.gains / 4 + out.length * 3);
  return out.map((f, c) => [g[3 * c], g[3 * c + 1], g[3 * c + 2]]);
}
