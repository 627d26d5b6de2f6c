// Drives Debian's Chromium (headless, SwiftShader WebGL2) through the Volcast web viewer for the
// browser tests (tests/net/web_test.cpp): opens the link, waits for decoded frames, and writes what
// the page measured (window.volcast) and a screenshot. With --xr, IWER (npm `iwer`) stands in
// for a Meta Quest 3: the page enters immersive-vr, renders both eyes, and publishes the
// emulated head and controllers; the emulated right trigger teleports, and the drive waits for
// the teleport, 30 headset frames and 60 poses sent (page.json's xr.frames, session.posesSent).
//
//   node drive.mjs --link URL --out DIR [--frames N] [--seconds S] [--xr] [--bench]
//                  [--stall S] [--unblended] [--chromium PATH]
// --seconds S: how long a wait may take before the page counts as broken (default 120 for the
// frame sets, each later wait its own; a loaded machine is slow); 0: no wait has a deadline, each
// ends on what it waits for (or the page's error), and the caller's timeout bounds a broken run.
// --stall: once the page has joined its session, blocks the page's main thread for S seconds
// (page.json's stalledMs), then goes on.
// --unblended: then waits until the page's frame budget has turned blending off (page.json's blend).
// --bench: then times the WebAssembly decoder on the newest frame (page.json's bench).
// --case: then waits for the patient case, aims at object 0 and presses G (grab), holds X for a
// second and 10 frames at least (it turns), G again (release), and ] 2 O on the monitor (next slice, liver window,
// overlay toggled), as a person at the keyboard would.
// --mic FILE: Chromium's fake microphone plays the WAV file once (then silence), as a person
// speaking; --voice S: once the page has heard someone's voice, S seconds more and until it has
// played what it received (a loaded page's audio runs behind), then writes what it played
// (window.volcastHeard, the page fragment's record=S) to DIR/heard.wav, and its played log
// (window.volcastHeardLog: Voice.heardLog in voice.js) to DIR/heard_played.tsv; with --mic, also
// what the microphone gave the page, on its frame numbers, to DIR/captured.wav.
// --volume NAME:GAIN: sets participant NAME's volume slider (the people panel) to GAIN (0-2).
// --ar X,Y,Z,DX,DY,DZ: IWER's headset enters immersive-ar instead (the page shows the others'
// pointers and annotations over the passthrough); once the page has drawn another participant's
// pointer dot (page.json's drawing.dot: the link needs the page's probe=1), the right controller stands at X,Y,Z (the headset's
// local-floor frame: the site's world frame) pointing along DX,DY,DZ, holds A for 8 headset
// frames (the pointer), then B while it turns by 1 degree every 2 frames, 10 times (a stroke), its
// thumbstick is pressed leant forward (a 'cut here' label), the drive waits for both to come back
// from the server and the other's pointer to be put away, then the left thumbstick is pressed (the
// label, the newest, erased) and it waits for the label to be gone (DIR/ar-pointer.png: the page when it first drew the other's dot).
// A page whose path is cut meanwhile also gets DIR/reconnecting.png (the page while it shows
// RECONNECTING) and DIR/overlay.png (the page at the end, overlay included).
// Writes DIR/page.json and DIR/desktop.png (or DIR/xr.png). Exit 0 when the page received N
// frame sets and drew without an error, else 1 with the reason on stderr.
import {chromium} from 'playwright-core';
import {writeFileSync} from 'node:fs';
import {createRequire} from 'node:module';

const args = process.argv.slice(2);
const flag = (name, fallback) => {
  const i = args.indexOf(name);
  return i >= 0 ? args[i + 1] : fallback;
};
const link = flag('--link');
const out = flag('--out', '.');
const frames = Number(flag('--frames', '30'));
const seconds = Number(flag('--seconds', '120'));  // bounds a broken page; a loaded box is slow
const bound = (ms) => (seconds > 0 ? ms : 0);      // a wait's deadline (0: none)
const ar = flag('--ar');
const xr = args.includes('--xr') || !!ar;
const mic = flag('--mic');
const voiceSeconds = Number(flag('--voice', '0'));
const executablePath = flag('--chromium', '/usr/bin/chromium');
if (!link) {
  console.error('usage: node drive.mjs --link URL --out DIR [--frames N] [--xr]');
  process.exit(2);
}

const browser = await chromium.launch({
  executablePath,
  headless: true,
  args: ['--no-sandbox', '--ignore-certificate-errors', '--disable-background-networking',
         '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-quic',
         '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
         '--autoplay-policy=no-user-gesture-required',
         ...(mic ? ['--use-fake-ui-for-media-stream', '--use-fake-device-for-media-stream',
                    `--use-file-for-fake-audio-capture=${mic}%noloop`] : [])],
});
let code = 1;
const console_ = [];
try {
  const page = await browser.newPage({viewport: {width: 800, height: 450}});
  page.setDefaultTimeout(bound(60000));  // a loaded 2-core machine renders SwiftShader slowly
  page.on('console', (m) => console_.push(`${m.type()}: ${m.text()}`));
  page.on('pageerror', (e) => console_.push(`pageerror: ${e.message}`));
  page.on('worker', (w) => w.on('console', (m) => console_.push(`worker ${m.type()}: ${m.text()}`)));
  if (xr) {
    const require = createRequire(import.meta.url);
    await page.addInitScript({path: require.resolve('iwer/build/iwer.min.js')});
    await page.addInitScript(() => {
      const device = new IWER.XRDevice(IWER.metaQuest3);
      device.installRuntime({forceInstall: true});
      device.position.set(0, 1.6, 0);
      window.iwerDevice = device;
    });
  }
  const started = Date.now();
  await page.goto(link);
  const deadline = started + seconds * 1000;
  const state = () => page.evaluate(() => JSON.parse(JSON.stringify(window.volcast || {})));
  // Until N frame sets and a picture (or an error), watched in the page: window.volcast is copied
  // out only when that is reached, or when the page first shows RECONNECTING (its screenshot).
  let reconnectingShot = false;
  for (;;) {
    const left = seconds > 0 ? deadline - Date.now() : 0;
    if (seconds > 0 && left <= 0) break;
    const shown = await page.waitForFunction(([n, shot]) => {
      const v = window.volcast;
      if (!v) return false;
      if (v.phase === 'error' || (v.framesReceived >= n && v.framesDrawn >= 1)) return 'done';
      return !shot && v.connection ? 'cut' : false;
    }, [frames, reconnectingShot], {timeout: left, polling: 100})
        .then((h) => h.jsonValue(), () => 'late');
    if (shown !== 'cut') break;
    await page.screenshot({path: `${out}/reconnecting.png`});  // what a person sees meanwhile
    reconnectingShot = true;
  }
  let s = await state();
  // --unblended: until the page's frame budget has turned blending off (frame_budget.js; a test
  // gives the page framems=1, a period no frame keeps).
  if (args.includes('--unblended') && s.phase !== 'error') {
    await page.waitForFunction(() => !window.volcast.blend.on, null, {timeout: bound(90000)});
    s = await state();
  }
  // --volume NAME:GAIN: once NAME is in the page's people panel, its volume slider set to GAIN,
  // as a person drags it.
  const volume = flag('--volume');
  if (volume && s.phase !== 'error') {
    const at = volume.lastIndexOf(':');
    await page.locator(`#people input[data-name="${volume.slice(0, at)}"]`)
        .fill(volume.slice(at + 1), {timeout: bound(60000)});
  }
  const stall = Number(flag('--stall', '0'));
  let stalledMs = 0;
  if (stall > 0 && s.phase !== 'error') {
    // The page's main thread blocked for S seconds once it is in a session, as a loaded headset
    // or a long upload to the GPU might: it must stay in the session (the worker's heartbeat).
    await page.waitForFunction(() => window.volcast.session.joined, null, {timeout: bound(60000)});
    stalledMs = await page.evaluate((ms) => {
      const t0 = performance.now();
      while (performance.now() - t0 < ms) {}
      return performance.now() - t0;
    }, stall * 1000);
    await page.waitForTimeout(1500);
    s = await state();
  }
  if (xr && s.phase !== 'error') {
    // In the page: a promise of `n` more headset frames from now (the runtime samples buttons and
    // poses once a frame), or of the page's error, so that what the drive does and the frames it
    // waits for after it cost one round trip (the page's main thread answers one between frames).
    await page.evaluate((ms) => {
      window.volcastFrames = (n) => new Promise((resolve, reject) => {
        const v = window.volcast, until = v.xr.frames + n, t0 = performance.now();
        const tick = () => {
          const late = ms > 0 && performance.now() - t0 > ms;
          if (v.xr.frames >= until || v.phase === 'error') resolve(v.xr.frames);
          else if (late) reject(new Error(`${n} headset frames took over ${ms} ms`));
          else setTimeout(tick, 10);
        };
        tick();
      });
    }, bound(30000));
  }
  if (ar && s.phase !== 'error') {
    await page.click('#enter-ar', {timeout: bound(60000)});
    await page.waitForFunction(() => window.volcast.drawing.dot && window.volcast.drawing.dot.rgba[3] > 0,
                               null, {timeout: bound(60000)});
    await page.screenshot({path: `${out}/ar-pointer.png`});  // what the headset shows then
    const [x, y, z, dx, dy, dz] = ar.split(',').map(Number);
    // The controller's -z along the direction turned by `yaw` about the vertical, then `n` frames.
    const aimAt = (yaw, n) => page.evaluate(([x, y, z, dx, dy, dz, yaw, after]) => {
      const c = Math.cos(yaw), s_ = Math.sin(yaw);
      const d = [c * dx + s_ * dz, dy, -s_ * dx + c * dz], n = Math.hypot(...d);
      const v = d.map((k) => k / n);
      // The shortest rotation taking (0, 0, -1) to v.
      const axis = [v[1], -v[0], 0], dot = -v[2];
      const w = 1 + dot;
      const q = w < 1e-6 ? [0, 1, 0, 0] : [...axis, w];
      const qn = Math.hypot(...q);
      const right = window.iwerDevice.controllers.right;
      right.position.set(x, y, z);
      right.quaternion.set(q[0] / qn, q[1] / qn, q[2] / qn, q[3] / qn);
      return window.volcastFrames(after);
    }, [x, y, z, dx, dy, dz, yaw, n]);
    await aimAt(0, 2);
    // A right-controller button set to `value`, then `n` frames.
    const press = (button, value, n) => page.evaluate(([b, v, n]) => {
      window.iwerDevice.controllers.right.updateButtonValue(b, v);
      return window.volcastFrames(n);
    }, [button, value, n]);
    await press('a-button', 1, 8);
    await press('a-button', 0, 3);
    await press('b-button', 1, 0);
    for (let i = 1; i <= 10; ++i)  // two frames each: the first may have begun before it
      await aimAt((i * Math.PI) / 180, 2);
    await press('b-button', 0, 0);
    // The right thumbstick leant forward and pressed: a 'cut here' label where the ray points.
    await page.evaluate(() => {
      const right = window.iwerDevice.controllers.right;
      right.updateAxes('thumbstick', 0, -1);
      right.updateButtonValue('thumbstick', 1);
      return window.volcastFrames(3);
    });
    await press('thumbstick', 0, 0);
    const mine = (n) => page.waitForFunction((n) => {
      const v = window.volcast;
      return v.drawing.annotations.filter((a) => a.author === v.session.id).length === n &&
             v.drawing.held.length === 0;
    }, n, {timeout: bound(30000)});
    await mine(2);
    s = await state();
    // The left thumbstick pressed: the newest (the label) erased for everyone.
    await page.evaluate(() => {
      window.iwerDevice.controllers.left.updateButtonValue('thumbstick', 1);
      return window.volcastFrames(3);
    });
    await page.evaluate(() => window.iwerDevice.controllers.left.updateButtonValue('thumbstick', 0));
    await mine(1);
  } else if (xr && s.phase !== 'error') {
    await page.click('#enter-vr', {timeout: bound(60000)});
    // Once the headset draws, move the emulated head and pull the right trigger pointing 1.2 rad
    // down at the floor about 0.7 m ahead (free floor from every spawn spot), held for 3 headset
    // frames (the runtime samples the trigger once a frame), then let go: WebXR's select, which
    // teleports.
    await page.waitForFunction(() => window.volcast.phase === 'error' || window.volcast.xr.frames,
                               null, {timeout: bound(60000)});
    await page.evaluate(() => {
      const d = window.iwerDevice;
      d.position.set(0.2, 1.5, -0.1);
      const right = d.controllers.right;
      right.position.set(0.2, 1.0, -0.3);
      right.quaternion.set(-Math.sin(0.6), 0, 0, Math.cos(0.6));
      right.updateButtonValue('trigger', 1);
      return window.volcastFrames(3);
    });
    await page.evaluate(() => window.iwerDevice.controllers.right.updateButtonValue('trigger', 0));
    // Then until the teleport came back, the headset drew 30 frames and the page sent 60 poses
    // (one a frame drawn), or the page's error: counted, not timed, as a loaded machine may draw
    // a frame every few seconds (a deadline only bounds a broken page).
    await page.waitForFunction(() => {
      const v = window.volcast;
      return v.phase === 'error' ||
             (v.session.teleports >= 1 && v.xr.frames >= 30 && v.session.posesSent >= 60);
    }, null, {timeout: bound(120000)}).catch(() => {});
    await page.waitForTimeout(1500);
    s = await state();
  }
  if (args.includes('--case') && s.phase !== 'error') {
    await page.waitForFunction(() => window.volcast.case && window.volcast.session.joined &&
                                     window.volcast.session.monitor,
                               null, {timeout: bound(120000)});
    await page.evaluate(() => window.volcastAim(0));
    await page.waitForTimeout(200);
    await page.keyboard.press('g');
    await page.waitForFunction(() => window.volcast.session.objects[0].owner === window.volcast.session.id,
                               null, {timeout: bound(120000)});
    // X held a second and for at least 10 page frames (each moves the held liver once): a loaded
    // machine may draw only a few frames a second, or (CI, beside the sanitized builds) one every
    // 2.4 s; the waits here are long for it.
    const pressedAt = await page.evaluate(() => window.volcast.desktopFrames);
    await page.keyboard.down('x');
    await page.waitForTimeout(1000);
    await page.waitForFunction((f) => window.volcast.desktopFrames >= f + 10, pressedAt,
                               {timeout: bound(180000)});
    await page.keyboard.up('x');
    await page.keyboard.press('g');
    await page.waitForFunction(() => window.volcast.session.objects[0].owner === 0, null,
                               {timeout: bound(120000)});
    for (const key of [']', '2', 'o']) {
      await page.keyboard.press(key);
      await page.waitForTimeout(300);
    }
    await page.waitForTimeout(1000);
    s = await state();
  }
  if (voiceSeconds > 0 && s.phase !== 'error') {
    await page.waitForFunction(() => window.volcast.voice &&
                                     Object.values(window.volcast.voice.heard).some((h) => h.frames > 0),
                               null, {timeout: bound(60000)});
    await page.waitForTimeout(voiceSeconds * 1000);
    // Then until the page has played what it received: a loaded page's audio thread, not run for
    // a while, leaves its context's clock behind the wall's for good (a CI run's page played
    // 1.5 s behind). Every speaker's playout has nothing waiting, and what the page kept reaches
    // the context time where that held (its tap posts blocks of up to 0.5 s).
    await page.waitForFunction(() => Object.values(window.volcast.voice.heard)
                                          .every((h) => h.waitingMs === 0),
                               null, {timeout: bound(60000)});
    const played = await page.evaluate(() => window.volcast.voice.contextTime);
    await page.waitForFunction((t) => window.volcast.voice.keptTo >= t ||
                                      window.volcast.voice.keptFull,
                               played, {timeout: bound(60000)});
    const wav = await page.evaluate(() => window.volcastHeard());
    writeFileSync(`${out}/heard.wav`, Buffer.from(wav, 'base64'));
    writeFileSync(`${out}/heard_played.tsv`, await page.evaluate(() => window.volcastHeardLog()));
    if (mic) {
      const captured = await page.evaluate(() => window.volcastCaptured());
      writeFileSync(`${out}/captured.wav`, Buffer.from(captured, 'base64'));
    }
    s = await state();
  }
  if (args.includes('--bench') && s.phase !== 'error') {
    await page.evaluate(() => window.volcastBench(200));
    await page.waitForFunction(() => window.volcast.bench, null, {timeout: bound(30000)});
    s = await state();
  }
  // After a cut, the page as a person sees it, overlay included (DIR/overlay.png).
  if (s.outages && s.outages.length) await page.screenshot({path: `${out}/overlay.png`});
  // The picture alone: the overlay's text would count as drawn pixels.
  await page.evaluate(() => {
    for (const id of ['overlay', 'people', 'help', 'enter-vr', 'enter-ar'])
      document.getElementById(id).hidden = true;
  });
  const shot = `${out}/${xr ? 'xr' : 'desktop'}.png`;
  await page.screenshot({path: shot});
  s.loadToFirstFrameMs = s.firstFrameMs;
  s.stalledMs = stalledMs;
  s.console = console_;
  writeFileSync(`${out}/page.json`, JSON.stringify(s, null, 1));
  if (s.phase === 'error') console.error('page error: ' + s.error);
  else if (s.framesReceived < frames || s.framesDrawn < 1)
    console.error(`only ${s.framesReceived} frame sets received, ${s.framesDrawn} pictures drawn`);
  else code = 0;
  if (code !== 0) console.error(console_.join('\n'));
} catch (e) {
  console.error(e);
  console.error(console_.join('\n'));  // what the page said, to tell why
} finally {
  await browser.close();
}
process.exit(code);
