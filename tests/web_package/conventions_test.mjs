// The export-conventions round trip in three.js (issue 41; the conventions:
// docs/reference/engine-conventions.md). The coloured-octant probe
// (tests/octant_probe.py: a cube whose eight octants have their own base
// colour) is baked by this build's farm, published with `impostor publish`,
// and the example page (examples/web/) draws it in headless Chromium from
// each octant's direction, as the glTF mesh and as the impostor. Asserted
// per direction, for both: the colour at the middle of the picture (the
// corner nearest the camera; median of 6 x 6 pixels) is that octant's
// palette entry within COLOUR_TOLERANCE levels per sRGB channel, and no
// other entry is nearer; over the impostor's picture, the octant each pixel
// shows agrees with the mesh's where the mesh is flat (away from edges) and
// the silhouettes agree (IoU). A flipped image row order, another up axis,
// a mirrored handedness or a map decoded in the wrong colour space shows
// another octant or a colour off the palette.
// Images (mesh, impostor) go to --artifacts DIR when given.
// Run: node --experimental-websocket tests/web_package/conventions_test.mjs
//        --bin BUILD/bin [--artifacts DIR] [--python python3]
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import { existsSync, mkdirSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { after, before, test } from 'node:test';
import { launchChromium } from './lib/chromium.mjs';
import { publishWithFarm } from './lib/farm_release.mjs';
import { encodePng } from './lib/png.mjs';
import { startStaticServer } from './lib/static_server.mjs';

const here = dirname(fileURLToPath(import.meta.url));
const repo = resolve(here, '..', '..');
const args = process.argv.slice(2);
const arg = (name, fallback) => {
  const i = args.indexOf(`--${name}`);
  return i >= 0 ? args[i + 1] : fallback;
};
const BIN = resolve(arg('bin', join(repo, 'build', 'bin')));
const PYTHON = arg('python', 'python3');
const THREE_DIR = arg('three', join(repo, 'web', 'node_modules', 'three'));
const CHROMIUM = arg('chromium', '/usr/bin/chromium');
const ARTIFACTS = arg('artifacts', process.env.IMPOSTOR_TEST_ARTIFACTS_DIR
  ? join(process.env.IMPOSTOR_TEST_ARTIFACTS_DIR, 'web_conventions') : '');
const SIZE = 256;
const ASSET = 'probes/octant';
const CHANNEL = 'nightly';

// sRGB levels per channel between what is drawn and the palette entry (the
// palette's entries are >= 60 apart in some channel).
const COLOUR_TOLERANCE = 20;
const WINDOW = 3;                 // the middle's median: 2 WINDOW x 2 WINDOW pixels about the centre
// Of the mesh's flat pixels (FLAT_MARGIN_PX from any other octant, colour
// or the background), the share where the impostor shows the same octant:
// 64 px frame tiles blended three at a time blur octant borders over ~5 px
// (measured 99.96-100 % at 6 px; a mirrored picture would agree on ~half).
const FLAT_MARGIN_PX = 6;
const MIN_LABEL_AGREEMENT = 0.98;
const MIN_IOU = 0.95;

let tmp, probe, servers = {}, browser;

before(async () => {
  assert.ok(existsSync(CHROMIUM), `${CHROMIUM} is not installed (deploy/install-deps.sh installs chromium)`);
  assert.ok(existsSync(join(THREE_DIR, 'build', 'three.module.js')), `${THREE_DIR}: no three.js (npm ci in web/)`);
  for (const b of ['impostor', 'impostor-server', 'impostor-worker']) {
    assert.ok(existsSync(join(BIN, b)), `${join(BIN, b)} is missing (build the farm)`);
  }
  tmp = mkdtempSync(join(tmpdir(), 'impostor-three-conventions-'));
  const glb = join(tmp, 'mesh', 'octant_probe.glb');
  mkdirSync(dirname(glb));
  const made = spawnSync(PYTHON, [join(repo, 'tests', 'octant_probe.py'), '--out', glb], { encoding: 'utf8' });
  assert.equal(made.status, 0, `octant_probe.py: ${made.stderr}`);
  probe = JSON.parse(made.stdout);
  const { release, keys } = await publishWithFarm({
    bin: BIN, dir: tmp, channel: CHANNEL,
    models: [{ name: ASSET, model: glb, options: { layout: 'octahedral', frames: 8, resolution: 512 } }],
  });
  console.log(`baked and published ${ASSET} = ${keys[ASSET]}`);
  if (ARTIFACTS) mkdirSync(ARTIFACTS, { recursive: true });
  servers.page = await startStaticServer([
    { prefix: '/web/node_modules/three/', dir: THREE_DIR },
    { prefix: '/packages/impostor-three/', dir: join(repo, 'packages', 'impostor-three') },
    { prefix: '/examples/web/', dir: join(repo, 'examples', 'web') },
    { prefix: '/mesh/', dir: dirname(glb) },
  ]);
  servers.mirror = await startStaticServer([{ prefix: '/', dir: release }]);
  browser = await (await launchChromium(CHROMIUM)).start();
});

after(async () => {
  await Promise.all(Object.values(servers).map((s) => s.close()));
  if (browser) await browser.close();
  if (tmp) rmSync(tmp, { recursive: true, force: true });
});

// The camera toward direction d (azimuth from +Z toward +X, elevation above
// the XZ plane), as the example page places it.
const cameraOf = ([x, y, z]) => [Math.atan2(x, z) * 180 / Math.PI, Math.asin(y / Math.hypot(x, y, z)) * 180 / Math.PI];

// The palette entry nearest `rgb` and its largest channel difference.
function nearest(rgb) {
  let best = null;
  for (const o of probe.octants) {
    const d = Math.max(...o.srgb.map((c, k) => Math.abs(c - rgb[k])));
    if (!best || d < best.d) best = { index: o.index, name: o.name, d };
  }
  return best;
}

// Per pixel: the octant index it shows (palette within tolerance), -1 for
// a colour off the palette, -2 uncovered.
function labels(rgba) {
  const out = new Int8Array(SIZE * SIZE);
  for (let i = 0; i < out.length; ++i) {
    if (rgba[i * 4 + 3] < 128) {
      out[i] = -2;
      continue;
    }
    const n = nearest([rgba[i * 4], rgba[i * 4 + 1], rgba[i * 4 + 2]]);
    out[i] = n.d <= COLOUR_TOLERANCE ? n.index : -1;
  }
  return out;
}

// The median colour of the middle window, and whether all of it is covered.
function middle(rgba) {
  const c = SIZE >> 1, px = [[], [], []];
  let covered = true;
  for (let y = c - WINDOW; y < c + WINDOW; ++y) {
    for (let x = c - WINDOW; x < c + WINDOW; ++x) {
      const i = (y * SIZE + x) * 4;
      if (rgba[i + 3] < 128) covered = false;
      for (let k = 0; k < 3; ++k) px[k].push(rgba[i + k]);
    }
  }
  return { rgb: px.map((v) => v.sort((a, b) => a - b)[v.length >> 1]), covered };
}

function flipRows(rgba) {
  const out = new Uint8Array(rgba.length);
  for (let y = 0; y < SIZE; ++y) out.set(rgba.subarray((SIZE - 1 - y) * SIZE * 4, (SIZE - y) * SIZE * 4), y * SIZE * 4);
  return out;
}

test('the octant probe shows the right colour from each of the 8 octant directions, as mesh and as impostor', async () => {
  const cameras = probe.octants.map((o) => cameraOf(o.direction));
  const url = `${servers.page.url}/examples/web/index.html?mirror=${encodeURIComponent(servers.mirror.url)}`
    + `&channel=${CHANNEL}&name=${encodeURIComponent(ASSET)}&mesh=/mesh/octant_probe.glb&count=1&forestMesh=none`
    + `&frames=1&size=${SIZE}&images=1&cameras=${cameras.map((c) => c.map((v) => v.toFixed(4)).join(',')).join(';')}`;
  await browser.open(url);
  const out = await browser.evaluate('window.impostorExample', 240000);
  assert.equal(out.error, '', out.error);
  assert.ok(out.files.every((f) => f.verified), JSON.stringify(out.files));
  assert.equal(out.views.length, 8);
  const failures = [], report = [];
  for (const [k, o] of probe.octants.entries()) {
    const v = out.views[k];
    const images = {};
    for (const side of ['mesh', 'impostor']) {
      images[side] = new Uint8Array(Buffer.from(await browser.evaluate(`window.impostorExampleImages[${JSON.stringify(v[side])}]`), 'base64'));
      if (ARTIFACTS) writeFileSync(join(ARTIFACTS, `octant_${o.name}_${side}.png`), encodePng(SIZE, SIZE, flipRows(images[side])));
      const m = middle(images[side]);
      const n = nearest(m.rgb);
      report.push(`${o.name} (camera az ${v.camera[0].toFixed(1)} el ${v.camera[1].toFixed(1)}) ${side}: middle `
        + `rgb(${m.rgb.join(', ')}), nearest ${n.name} off by ${n.d}; want ${o.name} rgb(${o.srgb.join(', ')})`);
      if (!m.covered) failures.push(`${o.name} ${side}: the middle of the picture is not covered`);
      else if (n.index !== o.index || n.d > COLOUR_TOLERANCE) {
        failures.push(`${o.name} ${side}: the middle shows rgb(${m.rgb.join(', ')}) (nearest ${n.name}, off by ${n.d}), `
          + `want ${o.name} rgb(${o.srgb.join(', ')}) within ${COLOUR_TOLERANCE}`);
      }
    }
    // Over the whole picture: the octant each pixel shows, mesh against impostor.
    const a = labels(images.mesh), b = labels(images.impostor);
    let both = 0, either = 0, flat = 0, agree = 0;
    const r = FLAT_MARGIN_PX;
    for (let y = r; y < SIZE - r; ++y) {
      for (let x = r; x < SIZE - r; ++x) {
        const i = y * SIZE + x;
        both += a[i] !== -2 && b[i] !== -2;
        either += a[i] !== -2 || b[i] !== -2;
        let isFlat = a[i] >= 0;
        for (let dy = -r; dy <= r && isFlat; ++dy) for (let dx = -r; dx <= r; ++dx) if (a[i + dy * SIZE + dx] !== a[i]) isFlat = false;
        if (!isFlat) continue;
        flat += 1;
        agree += b[i] === a[i];
      }
    }
    const iou = both / Math.max(1, either), agreement = agree / Math.max(1, flat);
    report.push(`${o.name}: silhouette IoU ${iou.toFixed(4)}, octant agreement ${(100 * agreement).toFixed(2)}% of ${flat} flat pixels`);
    if (iou < MIN_IOU) failures.push(`${o.name}: silhouette IoU ${iou.toFixed(4)} < ${MIN_IOU}`);
    if (agreement < MIN_LABEL_AGREEMENT) {
      failures.push(`${o.name}: the impostor shows the mesh's octant on ${(100 * agreement).toFixed(2)}% of its flat pixels, `
        + `want >= ${100 * MIN_LABEL_AGREEMENT}%`);
    }
  }
  console.log(report.join('\n'));
  assert.deepEqual(failures, [], `${failures.join('\n')}${ARTIFACTS ? `\nimages in ${ARTIFACTS}` : ''}`);
  assert.deepEqual(browser.consoleErrors, []);
});
