// The browser test on a release the farm's own publisher wrote: starts
// impostor-server with one local worker (port 0, a temporary data
// directory), bakes MODEL with `impostor bake` (PNG maps, and again as
// KTX2), publishes both with `impostor publish NAME=KEY NAME-ktx2=KEY2
// --channel nightly --out DIR`, stops the server (lib/farm_release.mjs),
// then runs browser_test.mjs on DIR with MODEL as the reference. Exits with
// the browser test's status (1 when a step before it fails, naming it).
// Usage: node --experimental-websocket published_release.mjs --bin BUILD/bin
//          --model MODEL.glb [--artifacts DIR] [--name props/box] [--frames 8]
//          [--resolution 512] [--layout octahedral]
import { spawnSync } from 'node:child_process';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';
import { publishWithFarm } from './lib/farm_release.mjs';

const here = dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const arg = (name, fallback) => {
  const i = args.indexOf(`--${name}`);
  return i >= 0 ? args[i + 1] : fallback;
};
const bin = arg('bin');
const model = arg('model');
const name = arg('name', 'props/box');
const channel = 'nightly';
if (!bin || !model) {
  console.error('usage: published_release.mjs --bin BUILD/bin --model MODEL.glb [--artifacts DIR]');
  process.exit(2);
}

const tmp = mkdtempSync(join(tmpdir(), 'impostor-three-published-'));
try {
  // The mesh baked twice: PNG maps, and KTX2 (UASTC with the baker's mips).
  const options = { layout: arg('layout', 'octahedral'), frames: arg('frames', '8'), resolution: arg('resolution', '512') };
  const { release, report } = await publishWithFarm({
    bin, dir: tmp, channel, models: [
      { name, model, options },
      { name: `${name}-ktx2`, model, options: { ...options, extra: ['--texture-format', 'ktx2', '--quality-views', '0'] } },
    ],
  });
  console.log(report);
  const browser = spawnSync(process.execPath, ['--experimental-websocket', join(here, 'browser_test.mjs'),
    '--release', release, '--asset', name, '--ktx2-asset', `${name}-ktx2`, '--channel', channel,
    '--reference-glb', model,
    ...(arg('artifacts') ? ['--artifacts', arg('artifacts')] : [])], { stdio: 'inherit', timeout: 480000 });
  process.exitCode = browser.status ?? 1;
} catch (e) {
  console.error(`published_release: set-up failed: ${e.message}`);
  process.exitCode = 1;
} finally {
  rmSync(tmp, { recursive: true, force: true });
}
