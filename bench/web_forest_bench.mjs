// The web forest bench (issue 41): one frame of a forest of --count trees
// drawn with impostors (impostor-three's InstancedImpostorMesh, one draw
// call) against the same forest drawn with the meshes they were baked from
// (one InstancedMesh per primitive, or --forest-mesh objects: one object per
// tree), in one run of the example page (examples/web/) in headless
// Chromium. The tree is baked by this build's farm and published with
// `impostor publish` first (tests/web_package/lib/farm_release.mjs), or read
// from a release you give. Target: impostors >= 10x faster at 10,000 trees.
//
// Run (after building the farm, and `npm ci` in web/ for three.js):
//   node --experimental-websocket bench/web_forest_bench.mjs
//     [--model ../shared/assets/vegetation/StylizedTree_ChrisCLP/jungletree.glb]
//     [--count 10000] [--size 512] [--frames 3] [--forest-mesh instanced|objects]
//     [--bin build/bin] [--layout hemi-octahedral] [--atlas-frames 12] [--resolution 1024]
//     [--reconstruction depth|parallax|plain] [--depth-offset 0|1]
//     [--release DIR --name NAME --channel nightly]   (a published release instead of a bake)
//     [--chromium /usr/bin/chromium]
// Prints the renderer, each forest's median frame (render + wait for it), its
// draw calls, and the ratio: the impostors with the asset's reconstruction
// (what its quality pass measured; depth-aware by default, with the pixel
// depth offset) and again with far settings (plain reconstruction, no depth
// offset: what a game uses for trees a few pixels tall), unless
// --reconstruction / --depth-offset choose one. Each frame is timed alone (render, then a
// 1-pixel readback); the first frame of each forest (shader compile, upload)
// is not counted.
import { mkdtempSync, rmSync } from 'node:fs';
import { cpus, tmpdir } from 'node:os';
import { basename, dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { CHROMIUM_FLAGS, launchChromium } from '../tests/web_package/lib/chromium.mjs';
import { publishWithFarm } from '../tests/web_package/lib/farm_release.mjs';
import { startStaticServer } from '../tests/web_package/lib/static_server.mjs';

const repo = resolve(dirname(fileURLToPath(import.meta.url)), '..');
const args = process.argv.slice(2);
const arg = (name, fallback) => {
  const i = args.indexOf(`--${name}`);
  return i >= 0 ? args[i + 1] : fallback;
};
const MODEL = resolve(arg('model', join(repo, '..', 'shared', 'assets', 'vegetation', 'StylizedTree_ChrisCLP', 'jungletree.glb')));
const COUNT = Number(arg('count', 10000));
const SIZE = Number(arg('size', 512));
const FRAMES = Number(arg('frames', 3));
const FOREST_MESH = arg('forest-mesh', 'instanced');
const BIN = resolve(arg('bin', join(repo, 'build', 'bin')));
const CHANNEL = arg('channel', 'nightly');
const THREE_DIR = arg('three', join(repo, 'web', 'node_modules', 'three'));
const CHROMIUM = arg('chromium', '/usr/bin/chromium');

const tmp = mkdtempSync(join(tmpdir(), 'impostor-web-forest-bench-'));
const servers = [];
let browser = null;
try {
  let release = arg('release', '');
  let name = arg('name', 'trees/bench');
  if (!release) {
    const t = Date.now();
    const baked = await publishWithFarm({
      bin: BIN, dir: tmp, channel: CHANNEL, models: [{ name, model: MODEL, options: {
        layout: arg('layout', 'hemi-octahedral'), frames: arg('atlas-frames', '12'), resolution: arg('resolution', '1024'),
        extra: ['--quality-views', '0'] } }],
    });
    release = baked.release;
    console.log(`baked and published ${name} = ${baked.keys[name]} from ${MODEL} in ${((Date.now() - t) / 1000).toFixed(0)} s`);
  }
  const page = await startStaticServer([
    { prefix: '/web/node_modules/three/', dir: THREE_DIR },
    { prefix: '/packages/impostor-three/', dir: join(repo, 'packages', 'impostor-three') },
    { prefix: '/examples/web/', dir: join(repo, 'examples', 'web') },
    { prefix: '/mesh/', dir: dirname(MODEL) },
  ]);
  servers.push(page);
  const mirror = await startStaticServer([{ prefix: '/', dir: release }]);
  servers.push(mirror);
  // A frame of 10,000 meshes on SwiftShader takes seconds: no GPU watchdog.
  browser = await (await launchChromium(CHROMIUM, 60000, ['--disable-gpu-watchdog'])).start();
  const base = `${page.url}/examples/web/index.html?mirror=${encodeURIComponent(mirror.url)}&channel=${CHANNEL}`
    + `&name=${encodeURIComponent(name)}&mesh=${encodeURIComponent(`/mesh/${basename(MODEL)}`)}&count=${COUNT}`
    + `&size=${SIZE}&frames=${FRAMES}&views=0`;
  const visit = async (query) => {
    await browser.open(base + query);
    const out = await browser.evaluate('window.impostorExample', 3600000);
    if (!out.ok) throw new Error(`the page failed: ${out.error}`);
    return out.forest;
  };
  // The forest with the material as the asset's quality pass measured it
  // (or as --reconstruction / --depth-offset say), beside the meshes; then,
  // unless those were given, once more with the settings a game picks for
  // trees a few pixels tall: plain reconstruction, no pixel depth offset
  // (which lets the GPU test depth before shading).
  const chosen = arg('reconstruction') || arg('depth-offset');
  const first = await visit(`&forestMesh=${FOREST_MESH}`
    + (arg('reconstruction') ? `&reconstruction=${arg('reconstruction')}` : '')
    + (arg('depth-offset') ? `&depthOffset=${arg('depth-offset')}` : ''));
  const far = chosen ? null : await visit('&forestMesh=none&reconstruction=plain&depthOffset=0');
  const renderer = await browser.evaluate(`(() => { const gl = document.getElementById('view').getContext('webgl2');
    const ext = gl.getExtension('WEBGL_debug_renderer_info');
    return ext ? gl.getParameter(ext.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER); })()`);
  const { mesh } = first;
  const row = (label, f) => `  ${label.padEnd(44)} ${f.ms.toFixed(1).padStart(8)} ms  (frames ${f.frameMs.map((x) => x.toFixed(0)).join(', ')}), `
    + `${f.calls} draw call(s)${mesh && f !== mesh ? `: ${(mesh.ms / f.ms).toFixed(1)}x faster than the meshes` : ''}`;
  console.log([
    `renderer: ${renderer} (Chromium ${CHROMIUM_FLAGS.filter((f) => f.includes('angle')).join(' ')}, ${cpus().length} cores)`,
    `forest of ${first.count} x ${basename(MODEL)} at ${SIZE} x ${SIZE}, median frame of ${FRAMES}:`,
    ...(mesh ? [row(`meshes (${FOREST_MESH})`, mesh)] : []),
    row(`impostors (${chosen ? 'as given' : 'the asset\'s reconstruction'})`, first.impostor),
    ...(far ? [row('impostors (far: plain, no depth offset)', far.impostor)] : []),
    `target: impostors >= 10x faster than the meshes at 10,000 trees`,
  ].join('\n'));
} catch (e) {
  console.error(`web_forest_bench: ${e.message}`);
  process.exitCode = 1;
} finally {
  await Promise.all(servers.map((s) => s.close()));
  if (browser) await browser.close();
  rmSync(tmp, { recursive: true, force: true });
}
