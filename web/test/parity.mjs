// Draws one frame set with the browser's renderer (web/page/renderer.js, the shared camera
// shaders) in Debian's Chromium (headless, SwiftShader WebGL2), for the browser-against-native
// test (tests/render/browser_parity_test.cpp), which draws the same set natively.
//
//   node parity.mjs --web DIR --in DIR [--chromium PATH]
// --web: the built page (share/volcast/web); --in: what the test wrote --
//   scene.json: {width, height, clipFromView (16, column-major), viewFromWorld (16),
//                cameras: [{width, height, intrinsics (15), worldFromCamera (16), gain (3)}],
//                settings: [{surface, blend, weighting, ...: renderer.js CAMERA_DEFAULTS}]}
//   camera_K.depth (uint16 mm, little-endian, row 0 at the top), camera_K.rays (float32 pairs
//   X/Z, Y/Z), camera_K.rgba (RGBA8; alpha 0 where the colour camera did not reach).
// Writes --in's browser_S.rgba for each setting S: width x height RGBA8, row 0 at the top,
// alpha 0 where nothing was drawn. Exit 0 when every picture was written, else 1 with the
// reason on stderr.
import {chromium} from 'playwright-core';
import {readFileSync, writeFileSync} from 'node:fs';
import {extname, join} from 'node:path';

const args = process.argv.slice(2);
const flag = (name, fallback) => {
  const i = args.indexOf(name);
  return i >= 0 ? args[i + 1] : fallback;
};
const web = flag('--web');
const input = flag('--in');
const executablePath = flag('--chromium', '/usr/bin/chromium');
if (!web || !input) {
  console.error('usage: node parity.mjs --web DIR --in DIR');
  process.exit(2);
}

// The page: the renderer on a canvas the scene's size, each setting drawn and read back.
const PAGE = `<!doctype html><canvas id="c"></canvas><script type="module">
import {Renderer} from '/web/renderer.js';
import {identity, multiply} from '/web/math.js';
const get = async (name) => (await fetch('/in/' + name)).arrayBuffer();
try {
  const spec = await (await fetch('/in/scene.json')).json();
  const canvas = document.getElementById('c');
  canvas.width = spec.width;
  canvas.height = spec.height;
  const gl = canvas.getContext('webgl2', {antialias: false, preserveDrawingBuffer: true});
  const r = new Renderer(gl);
  const cams = [];
  for (let k = 0; k < spec.cameras.length; ++k) {
    const c = spec.cameras[k];
    cams.push({width: c.width, height: c.height, intrinsics: c.intrinsics,
               siteFromCamera: new Float32Array(c.worldFromCamera),
               rays: new Float32Array(await get('camera_' + k + '.rays'))});
  }
  r.setCameras(cams);
  for (let k = 0; k < cams.length; ++k) {
    r.cameraPass.uploadCamera(r.cameras[k],
                              {depth: new Uint16Array(await get('camera_' + k + '.depth')),
                               rgba: new Uint8Array(await get('camera_' + k + '.rgba'))});
    r.cameras[k].gain = spec.cameras[k].gain;
  }
  const viewFromRoom = new Float32Array(spec.viewFromWorld);
  const clipFromRoom = multiply(new Float32Array(spec.clipFromView), viewFromRoom);
  const pictures = [];
  const w = spec.width, h = spec.height;
  for (const settings of spec.settings) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.clearColor(0, 0, 0, 0);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    r.draw(clipFromRoom, [0, 0, w, h], {roomFromSite: identity(), viewFromRoom, ...settings});
    const bottomUp = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, bottomUp);
    const out = new Uint8Array(w * h * 4);
    for (let y = 0; y < h; ++y) out.set(bottomUp.subarray((h - 1 - y) * w * 4, (h - y) * w * 4), y * w * 4);
    let s = '';
    for (let i = 0; i < out.length; i += 0x8000) s += String.fromCharCode(...out.subarray(i, i + 0x8000));
    pictures.push(btoa(s));
  }
  const e = gl.getError();
  window.parity = e ? {error: 'WebGL error ' + e} : {pictures};
} catch (e) {
  window.parity = {error: String(e && e.stack || e)};
}
</script>`;

const TYPES = {'.js': 'text/javascript', '.json': 'application/json', '.html': 'text/html'};
const browser = await chromium.launch({
  executablePath,
  headless: true,
  args: ['--no-sandbox', '--disable-background-networking', '--disable-component-update',
         '--disable-sync', '--no-first-run', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});
let code = 1;
try {
  const page = await browser.newPage();
  page.setDefaultTimeout(120000);  // SwiftShader on a loaded 2-core machine
  const log = [];
  page.on('console', (m) => log.push(`${m.type()}: ${m.text()}`));
  page.on('pageerror', (e) => log.push(`pageerror: ${e.message}`));
  // Everything from disk under one made-up origin: no server, and module scripts allowed.
  await page.route('http://volcast.test/**', (route) => {
    const path = new URL(route.request().url()).pathname;
    if (path === '/parity.html') return route.fulfill({body: PAGE, contentType: 'text/html'});
    const [root, rest] = path.startsWith('/web/') ? [web, path.slice(5)] :
                         path.startsWith('/in/') ? [input, path.slice(4)] : [null, null];
    if (!root || rest.includes('..')) return route.fulfill({status: 404});
    try {
      return route.fulfill({body: readFileSync(join(root, rest)),
                            contentType: TYPES[extname(rest)] || 'application/octet-stream'});
    } catch {
      return route.fulfill({status: 404});
    }
  });
  await page.goto('http://volcast.test/parity.html');
  await page.waitForFunction(() => window.parity);
  const result = await page.evaluate(() => window.parity);
  if (result.error) throw new Error(result.error + '\n' + log.join('\n'));
  result.pictures.forEach((b64, s) => writeFileSync(join(input, `browser_${s}.rgba`), Buffer.from(b64, 'base64')));
  code = 0;
} catch (e) {
  console.error('parity: ' + (e && e.stack || e));
} finally {
  await browser.close();
}
process.exit(code);
