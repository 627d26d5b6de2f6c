// The browser's colour balance (the native renderer's colour_balance.cpp in the page's
// WebAssembly module, as web/page/worker.js calls it) on the frame set that
// tests/render/browser_parity_test.cpp wrote, in Node without a browser.
//
//   node balance.mjs --web DIR --in DIR
// --web: the built page (share/volcast/web, volcast_decoder.js); --in: parity.mjs's folder
// (scene.json's cameras also carry k: 17 intrinsics, and pose: 12 numbers, world_from_camera's
// rotation row-major and translation). Prints the gains as JSON: [[r, g, b]] by camera.
import {createRequire} from 'node:module';
import {readFileSync} from 'node:fs';
import {join} from 'node:path';

const args = process.argv.slice(2);
const flag = (name) => {
  const i = args.indexOf(name);
  return i >= 0 ? args[i + 1] : undefined;
};
const web = flag('--web'), input = flag('--in');
if (!web || !input) {
  console.error('usage: node balance.mjs --web DIR --in DIR');
  process.exit(2);
}
const VolcastDecoder = createRequire(import.meta.url)(join(web, 'volcast_decoder.js'));
// The binary handed over: Node's fetch would take the file's path for a URL.
const wasm = await VolcastDecoder({wasmBinary: readFileSync(join(web, 'volcast_decoder.wasm'))});
const fail = (what) => {
  console.error(`balance: ${what}: ${wasm.UTF8ToString(wasm._vc_last_error())}`);
  process.exit(1);
};
const scene = JSON.parse(readFileSync(join(input, 'scene.json'), 'utf8'));
const k = wasm._malloc(17 * 8), pose = wasm._malloc(12 * 8);
scene.cameras.forEach((c, i) => {
  wasm.HEAPF64.set(c.k, k / 8);
  wasm.HEAPF64.set(c.pose, pose / 8);
  if (wasm._vc_balance_camera(i, k, pose) !== 0) fail(`camera ${i}`);
  const depth = readFileSync(join(input, `camera_${i}.depth`));
  const rgba = readFileSync(join(input, `camera_${i}.rgba`));
  const d = wasm._malloc(depth.length), p = wasm._malloc(rgba.length);
  wasm.HEAPU8.set(depth, d);
  wasm.HEAPU8.set(rgba, p);
  if (wasm._vc_balance_take(i, d, p) < 0) fail(`camera ${i}'s samples`);
});
const n = scene.cameras.length, out = wasm._malloc(n * 3 * 4);
if (wasm._vc_balance_gains(n, out) !== 0) fail('gains');
const g = wasm.HEAPF32.subarray(out / 4, out / 4 + n * 3);
console.log(JSON.stringify(scene.cameras.map((c, i) => [g[3 * i], g[3 * i + 1], g[3 * i + 2]])));
