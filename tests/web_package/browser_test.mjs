// impostor-three in a real browser: headless Chromium (Debian's, on
// SwiftShader) opens the example page, examples/web/, which loads an asset of
// a published release from mirrors served by Node.js on port 0, and draws it
// from eight cameras between the baked frames, as an ImpostorMesh beside the
// mesh it was baked from, then a forest as meshes and as one
// InstancedImpostorMesh. Asserted:
//  1. first visit (mirrors: one serving a blob with a flipped byte, then a
//     good one): every file verified, the tampered one taken from the good
//     mirror; per camera the impostor's silhouette against the reference's
//     (IoU >= 0.95), covered where the reference is and background more than
//     2 px outside it, colours where both cover within the tolerance below;
//     the forest of 16 the same way (IoU >= 0.9) in one draw call; the first
//     view mid cross-fade (t 0.5, one InstancedImpostorMesh instance) keeps
//     the pixels crossFadeDrawsImpostor gives it, about half;
//  2. second visit, same profile, a forest of 10,000: no blob and no catalog
//     requested over the network (Network domain and the mirrors' logs),
//     every file from Cache Storage, the same pixels, the 10,000 instances in
//     at most 2 draw calls;
//  3. the tampered mirror alone, a fresh cache: the load is refused with an
//     error naming the file and both digests, and nothing is drawn;
//  4. with --ktx2-asset NAME (the same mesh baked with --texture-format
//     ktx2 in the same release): its maps go through three's KTX2Loader and
//     the Basis transcoder of the `three` package, and it draws as the
//     reference within the same silhouette bounds.
// Images (reference, impostor, difference) go to --artifacts DIR.
//
// The release: --release DIR (or IMPOSTOR_RELEASE_DIR) with --asset NAME,
// --channel NAME and --reference-glb FILE (the mesh the asset was baked
// from), e.g. one `impostor publish` wrote; without it a synthetic box
// result is published by lib/publish_release.mjs (release_format.md) into a
// temporary directory, with the box it stands for as a .glb.
// Run: node --experimental-websocket tests/web_package/browser_test.mjs [options]
import assert from 'node:assert/strict';
import { createHash } from 'node:crypto';
import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { after, before, test } from 'node:test';
import { boxGlb } from './lib/box_model.mjs';
import { launchChromium } from './lib/chromium.mjs';
import { encodePng } from './lib/png.mjs';
import { publishRelease } from './lib/publish_release.mjs';
import { startStaticServer } from './lib/static_server.mjs';
import { writeSyntheticResult } from './lib/synthetic_result.mjs';
import { crossFadeDrawsImpostor } from '../../packages/impostor-three/src/cross_fade.js';

const here = dirname(fileURLToPath(import.meta.url));
const repo = resolve(here, '..', '..');
const args = process.argv.slice(2);
const arg = (name, fallback) => {
  const i = args.indexOf(`--${name}`);
  return i >= 0 ? args[i + 1] : fallback;
};
const SIZE = 256;
const THREE_DIR = arg('three', join(repo, 'web', 'node_modules', 'three'));
const CHROMIUM = arg('chromium', '/usr/bin/chromium');
const ARTIFACTS = arg('artifacts', process.env.IMPOSTOR_TEST_ARTIFACTS_DIR
  ? join(process.env.IMPOSTOR_TEST_ARTIFACTS_DIR, 'web_package') : join(tmpdir(), 'impostor-three-artifacts'));

// Tolerances. The reference is drawn without antialiasing, the impostor
// from an 8 x 8 atlas of 64 px tiles at about 1.6 texels per pixel.
const MIN_VIEW_IOU = 0.95;
const MIN_FOREST_IOU = 0.9;
const MAX_OUTSIDE_FRACTION = 0.002;  // impostor pixels > 2 px outside the reference, of the reference's
const MAX_HOLE_FRACTION = 0.002;     // reference pixels > 2 px inside its edge the impostor misses
// Colour: where the reference is flat (no face edge or silhouette within
// 4 px; the atlas's texels are about 3.7 px here, so bilinear filtering
// blends faces over that width), the impostor's albedo within 24 levels.
const MAX_OFF_COLOUR_FRACTION = 0.01;
const FLAT_MARGIN_PX = 4;

const sha256 = (bytes) => createHash('sha256').update(bytes).digest('hex');

let tmp, release, channel, assetName, ktx2Asset, reference, synthetic = false, servers = {}, browser;

before(async () => {
  assert.ok(existsSync(CHROMIUM), `${CHROMIUM} is not installed (deploy/install-deps.sh installs chromium)`);
  assert.ok(existsSync(join(THREE_DIR, 'build', 'three.module.js')), `${THREE_DIR}: no three.js (npm ci in web/)`);
  tmp = mkdtempSync(join(tmpdir(), 'impostor-three-browser-'));
  release = arg('release', process.env.IMPOSTOR_RELEASE_DIR || '');
  channel = arg('channel', 'nightly');
  assetName = arg('asset', 'props/box');
  reference = arg('reference-glb', '');
  ktx2Asset = arg('ktx2-asset', '');
  if (!release) {
    const result = join(tmp, 'box');
    writeSyntheticResult(result, { layout: 'octahedral', frames: 8, resolution: 512 });
    release = join(tmp, 'release');
    publishRelease({ out: release, channel, assets: [{ name: assetName, dir: result }] });
    synthetic = true;
    mkdirSync(join(tmp, 'mesh'));
    reference = join(tmp, 'mesh', 'box.glb');
    writeFileSync(reference, boxGlb());
  }
  mkdirSync(ARTIFACTS, { recursive: true });
  // The repository's layout, as the example page's import map expects it.
  servers.page = await startStaticServer([
    { prefix: '/web/node_modules/three/', dir: THREE_DIR },
    { prefix: '/packages/impostor-three/', dir: join(repo, 'packages', 'impostor-three') },
    { prefix: '/examples/web/', dir: join(repo, 'examples', 'web') },
    { prefix: '/reference/', dir: dirname(resolve(reference)) },
  ]);
  const catalog = catalogOf(release, channel);
  const albedo = catalog.assets[assetName].files.find((f) => f.semantic === 'albedo_alpha');
  servers.albedo = albedo;
  servers.tampered = await startStaticServer([{ prefix: '/', dir: release }], { tamper: (p) => p.endsWith(albedo.sha256) });
  servers.good = await startStaticServer([{ prefix: '/', dir: release }]);
  browser = await (await launchChromium(CHROMIUM)).start();
});

after(async () => {
  await Promise.all(['page', 'tampered', 'good'].filter((k) => servers[k]).map((k) => servers[k].close()));
  if (browser) await browser.close();
  if (tmp) rmSync(tmp, { recursive: true, force: true });
});

function catalogOf(root, name) {
  const pointer = JSON.parse(readFileSync(join(root, 'v1', 'channels', `${name}.json`), 'utf8'));
  const hex = pointer.catalog.sha256;
  return JSON.parse(readFileSync(join(root, 'v1', 'catalogs', 'sha256', hex.slice(0, 2), hex), 'utf8'));
}

function pageUrl(mirrors, extra = '', name = assetName, count = 16) {
  return `${servers.page.url}/examples/web/index.html?${mirrors.map((m) => `mirror=${encodeURIComponent(m)}`).join('&')}`
    + `&channel=${encodeURIComponent(channel)}&name=${encodeURIComponent(name)}&count=${count}&size=${SIZE}&images=1`
    + `&frames=1&mesh=${encodeURIComponent(`/reference/${reference.split('/').pop()}`)}${extra}`;
}

async function visit(url) {
  const before = browser.requests.length;
  await browser.open(url);
  let out;
  try {
    out = await browser.evaluate('window.impostorExample', 240000);
  } catch (e) {
    const stage = await browser.evaluate('window.impostorExampleStage', 10000).catch(() => '?');
    throw new Error(`${e.message} (page stage: ${stage}; console: ${browser.consoleErrors.join(' | ').slice(0, 2000)})`);
  }
  // The images, one reply each.
  const image = (name) => browser.evaluate(`window.impostorExampleImages[${JSON.stringify(name)}]`);
  for (const v of out.views || []) {
    v.mesh = await image(v.mesh);
    v.impostor = await image(v.impostor);
  }
  if (out.fade) out.fade.images = { faded: await image(out.fade.image), whole: await image(out.fade.whole) };
  if (out.forest && out.forest.mesh && out.forest.count <= 100) {
    out.forest.images = { mesh: await image(out.forest.mesh.image), impostor: await image(out.forest.impostor.image) };
  }
  return { out, requests: browser.requests.slice(before).map((r) => r.url) };
}

// Rows top first for PNGs (readPixels gives bottom first).
function flipRows(rgba) {
  const out = new Uint8Array(rgba.length);
  for (let y = 0; y < SIZE; ++y) out.set(rgba.subarray((SIZE - 1 - y) * SIZE * 4, (SIZE - y) * SIZE * 4), y * SIZE * 4);
  return out;
}

const decode = (b64) => new Uint8Array(Buffer.from(b64, 'base64'));
const covered = (rgba, i) => rgba[i * 4 + 3] >= 128;

// Pixels within `r` px (Chebyshev) of a covered pixel of `mask`.
function grow(mask, r) {
  const out = new Uint8Array(mask.length);
  for (let y = 0; y < SIZE; ++y) {
    for (let x = 0; x < SIZE; ++x) {
      if (!mask[y * SIZE + x]) continue;
      for (let dy = -r; dy <= r; ++dy) {
        for (let dx = -r; dx <= r; ++dx) {
          const yy = y + dy, xx = x + dx;
          if (yy >= 0 && yy < SIZE && xx >= 0 && xx < SIZE) out[yy * SIZE + xx] = 1;
        }
      }
    }
  }
  return out;
}

// The impostor against the reference: IoU, pixels outside / holes inside
// (beyond 2 px of the reference's edge), colour differences where both
// cover; writes the three images.
function compare(name, meshB64, impostorB64) {
  const mesh = decode(meshB64), imp = decode(impostorB64);
  const n = SIZE * SIZE;
  const a = new Uint8Array(n), b = new Uint8Array(n);
  for (let i = 0; i < n; ++i) {
    a[i] = covered(mesh, i) ? 1 : 0;
    b[i] = covered(imp, i) ? 1 : 0;
  }
  const near = grow(a, 2);
  // Reference pixels next to another colour or the background, grown.
  const edge = new Uint8Array(n);
  for (let y = 0; y < SIZE; ++y) {
    for (let x = 0; x < SIZE; ++x) {
      const i = y * SIZE + x;
      for (const j of [x > 0 ? i - 1 : -1, x + 1 < SIZE ? i + 1 : -1, y > 0 ? i - SIZE : -1, y + 1 < SIZE ? i + SIZE : -1]) {
        if (j < 0 || a[i] !== a[j]) {
          edge[i] = 1;
          continue;
        }
        for (let k = 0; k < 3; ++k) if (Math.abs(mesh[i * 4 + k] - mesh[j * 4 + k]) > 2) edge[i] = 1;
      }
    }
  }
  const nearEdge = grow(edge, FLAT_MARGIN_PX);
  const notA = new Uint8Array(n).map((_, i) => 1 - a[i]);
  const nearOutside = grow(notA, 2);  // within 2 px of the background
  let both = 0, either = 0, meshCount = 0, outside = 0, holes = 0, off = 0, flat = 0, se = 0;
  const diff = new Uint8Array(n * 4);
  for (let i = 0; i < n; ++i) {
    both += a[i] & b[i];
    either += a[i] | b[i];
    meshCount += a[i];
    if (b[i] && !near[i]) outside += 1;
    if (a[i] && !nearOutside[i] && !b[i]) holes += 1;
    diff[i * 4 + 3] = a[i] || b[i] ? 255 : 0;
    if (a[i] !== b[i]) diff[i * 4] = 255;
    if (a[i] && b[i]) {
      let worst = 0;
      for (let k = 0; k < 3; ++k) {
        const d = Math.abs(mesh[i * 4 + k] - imp[i * 4 + k]);
        worst = Math.max(worst, d);
        se += (d / 255) ** 2;
        diff[i * 4 + k] = Math.min(255, d * 4);
      }
      if (!nearEdge[i]) {
        flat += 1;
        off += worst > 24;
      }
    }
  }
  writeFileSync(join(ARTIFACTS, `${name}_reference.png`), encodePng(SIZE, SIZE, flipRows(mesh)));
  writeFileSync(join(ARTIFACTS, `${name}_impostor.png`), encodePng(SIZE, SIZE, flipRows(imp)));
  writeFileSync(join(ARTIFACTS, `${name}_diff.png`), encodePng(SIZE, SIZE, flipRows(diff)));
  const mse = se / Math.max(1, 3 * both);
  return {
    iou: both / Math.max(1, either), meshFraction: meshCount / n, outside: outside / Math.max(1, meshCount),
    holes: holes / Math.max(1, meshCount), flat: flat / Math.max(1, meshCount), offColour: off / Math.max(1, flat), psnr: mse > 0 ? 10 * Math.log10(1 / mse) : 99,
  };
}

const isRelease = (url) => url.includes('/v1/blobs/') || url.includes('/v1/catalogs/');

let first = null;

test('first visit: verified from a published release, the tampered blob taken from the next mirror, drawn as the reference', async () => {
  const { out } = await visit(pageUrl([servers.tampered.url, servers.good.url], '&fade=0.5'));
  assert.equal(out.error, '', out.error);
  assert.ok(out.ok);
  first = out;
  const catalogFiles = catalogOf(release, channel).assets[assetName].files;
  assert.ok(out.files.length >= 3, JSON.stringify(out.files));
  for (const f of out.files) {
    assert.equal(f.verified, true, f.name);
    assert.equal(f.source, 'network', f.name);
    assert.equal(f.sha256, catalogFiles.find((c) => c.name === f.name).sha256, f.name);
  }
  const albedo = out.files.find((f) => f.semantic === 'albedo_alpha');
  assert.ok(albedo.url.startsWith(servers.good.url), `the tampered albedo came from ${albedo.url}`);
  assert.ok(servers.tampered.requests.some((r) => r.path.endsWith(servers.albedo.sha256)), 'the tampered mirror was asked first');

  const report = [];
  for (const v of out.views) {
    const name = `view_${v.camera.join('_')}`;
    const m = compare(name, v.mesh, v.impostor);
    report.push(`${name}: IoU ${m.iou.toFixed(4)}, outside ${(100 * m.outside).toFixed(2)}%, holes ${(100 * m.holes).toFixed(2)}%, `
      + `off-colour ${(100 * m.offColour).toFixed(2)}% of ${(100 * m.flat).toFixed(0)}% flat, PSNR ${m.psnr.toFixed(1)} dB`);
    assert.ok(m.meshFraction > 0.03, `${name}: the reference covers ${m.meshFraction}`);
    assert.ok(m.iou >= MIN_VIEW_IOU, `${name}: silhouette IoU ${m.iou} < ${MIN_VIEW_IOU}; images in ${ARTIFACTS}`);
    assert.ok(m.outside <= MAX_OUTSIDE_FRACTION, `${name}: ${m.outside} of the impostor lies beyond 2 px of the reference`);
    assert.ok(m.holes <= MAX_HOLE_FRACTION, `${name}: ${m.holes} of the reference's inside is not covered`);
    // The synthetic box is flat colour; a textured reference is checked where it has flat areas.
    if (synthetic) assert.ok(m.flat > 0.5, `${name}: only ${m.flat} of the box is flat colour`);
    if (m.flat >= 0.1) assert.ok(m.offColour <= MAX_OFF_COLOUR_FRACTION, `${name}: ${m.offColour} of flat pixels off by > 24 levels`);
  }
  const f = compare('forest', out.forest.images.mesh, out.forest.images.impostor);
  report.push(`forest of 16: IoU ${f.iou.toFixed(4)}, off-colour ${(100 * f.offColour).toFixed(2)}% of ${(100 * f.flat).toFixed(0)}% flat, `
    + `${out.forest.impostor.calls} draw call(s); load ${out.loadMs.toFixed(0)} ms`);
  console.log(report.join('\n'));
  assert.ok(f.iou >= MIN_FOREST_IOU, `forest: silhouette IoU ${f.iou} < ${MIN_FOREST_IOU}; images in ${ARTIFACTS}`);
  // Each instance turned its own way shows its own faces.
  if (f.flat >= 0.05) assert.ok(f.offColour <= MAX_OFF_COLOUR_FRACTION, `forest: ${f.offColour} of flat pixels off by > 24 levels`);
  assert.equal(out.forest.impostor.calls, 1, 'the forest of 16 is one draw call');

  // Mid cross-fade: readPixels rows are gl_FragCoord's, so pixel (x, y) of
  // the image is the shader's pixel. The instanced draw may differ from the
  // ImpostorMesh's at a few silhouette pixels (float rounding).
  const faded = decode(out.fade.images.faded), whole = decode(out.fade.images.whole);
  let kept = 0, object = 0, wrong = 0;
  for (let y = 0; y < SIZE; ++y) {
    for (let x = 0; x < SIZE; ++x) {
      const i = y * SIZE + x;
      const want = covered(whole, i) && crossFadeDrawsImpostor(out.fade.t, out.fade.seed, x, y);
      wrong += covered(faded, i) !== want ? 1 : 0;
      kept += covered(faded, i) ? 1 : 0;
      object += covered(whole, i) ? 1 : 0;
    }
  }
  console.log(`cross-fade t ${out.fade.t}: ${kept} of ${object} pixels kept (${(kept / object).toFixed(3)}), ${wrong} not the dither's`);
  writeFileSync(join(ARTIFACTS, 'fade_impostor.png'), encodePng(SIZE, SIZE, flipRows(faded)));
  assert.ok(Math.abs(kept / object - out.fade.t) <= 0.05, `cross-fade: ${kept} of ${object} pixels kept at t ${out.fade.t}`);
  assert.ok(wrong <= 0.01 * object, `cross-fade: ${wrong} pixels not as the dither gives them`);
  assert.deepEqual(browser.consoleErrors, []);
});

test('second visit: nothing from the release is downloaded again (Cache Storage); 10,000 instances in at most 2 draw calls', async () => {
  assert.ok(first, 'the first visit failed');
  const logged = { good: servers.good.requests.length, tampered: servers.tampered.requests.length };
  const { out, requests } = await visit(pageUrl([servers.tampered.url, servers.good.url], '', assetName, 10000));
  assert.equal(out.error, '', out.error);
  assert.deepEqual(requests.filter(isRelease), [], 'the page requested release files');
  const served = [...servers.good.requests.slice(logged.good), ...servers.tampered.requests.slice(logged.tampered)]
    .map((r) => r.path);
  assert.deepEqual(served.filter(isRelease), [], 'a mirror served release files');
  assert.ok(served.some((p) => p.includes('/v1/channels/')), 'the channel file is read again (no-cache)');
  for (const f of out.files) {
    assert.equal(f.source, 'cache', f.name);
    assert.equal(f.verified, true, f.name);
  }
  for (let i = 0; i < out.views.length; ++i) {
    assert.equal(sha256(out.views[i].impostor), sha256(first.views[i].impostor), `view ${i} drew other pixels`);
  }
  const { impostor, mesh } = out.forest;
  console.log(`forest of ${out.forest.count} at ${SIZE} px on SwiftShader: impostors ${impostor.ms.toFixed(0)} ms in `
    + `${impostor.calls} draw call(s), meshes (${mesh.mode}) ${mesh.ms.toFixed(0)} ms in ${mesh.calls}`);
  assert.equal(out.forest.count, 10000);
  assert.ok(impostor.calls >= 1 && impostor.calls <= 2, `10,000 instances took ${impostor.calls} draw calls`);
});

test('the tampered mirror alone: refused, naming the file and both digests, nothing drawn', async () => {
  const { out } = await visit(pageUrl([servers.tampered.url], '&cache=impostor-test-tampered'));
  assert.equal(out.ok, false);
  const albedo = servers.albedo;
  const bytes = Buffer.from(readFileSync(join(release, 'v1/blobs/sha256', albedo.sha256.slice(0, 2), albedo.sha256)));
  bytes[bytes.length >> 1] ^= 1;
  assert.ok(out.error.includes(albedo.name), out.error);
  assert.ok(out.error.includes(albedo.sha256), out.error);
  assert.ok(out.error.includes(sha256(bytes)), out.error);
  assert.equal(out.blankAfterError, true, 'something was drawn');
});

test('KTX2 maps: transcoded by three\'s KTX2Loader, drawn as the reference', { skip: !arg('ktx2-asset', '') && 'no --ktx2-asset' }, async () => {
  const { out } = await visit(pageUrl([servers.good.url], '&cache=impostor-test-ktx2', ktx2Asset));
  assert.equal(out.error, '', out.error);
  const maps = out.files.filter((f) => f.name.endsWith('.ktx2'));
  assert.ok(maps.length >= 2, `no KTX2 maps in ${JSON.stringify(out.files.map((f) => f.name))}`);
  assert.ok(out.files.every((f) => f.verified), 'every file verified');
  const report = [];
  for (const v of out.views) {
    const name = `ktx2_view_${v.camera.join('_')}`;
    const m = compare(name, v.mesh, v.impostor);
    report.push(`${name}: IoU ${m.iou.toFixed(4)}, outside ${(100 * m.outside).toFixed(2)}%, holes ${(100 * m.holes).toFixed(2)}%, PSNR ${m.psnr.toFixed(1)} dB`);
    assert.ok(m.iou >= MIN_VIEW_IOU, `${name}: silhouette IoU ${m.iou} < ${MIN_VIEW_IOU}; images in ${ARTIFACTS}`);
    assert.ok(m.outside <= MAX_OUTSIDE_FRACTION, `${name}: ${m.outside} of the impostor lies beyond 2 px of the reference`);
    assert.ok(m.holes <= MAX_HOLE_FRACTION, `${name}: ${m.holes} of the reference's inside is not covered`);
  }
  console.log(report.join('\n'));
  assert.deepEqual(browser.consoleErrors, []);
});
