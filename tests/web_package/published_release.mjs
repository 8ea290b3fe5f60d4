// The browser test on a release the farm's own publisher wrote: starts
// impostor-server with one local worker (port 0, a temporary data
// directory), bakes MODEL with `impostor bake` (PNG maps, and again as
// KTX2), publishes both with `impostor publish NAME=KEY NAME-ktx2=KEY2
// --channel nightly --out DIR`, stops the server, then runs browser_test.mjs
// on DIR with MODEL as the reference. Exits with
// the browser test's status (1 when a step before it fails, naming it).
// Usage: node --experimental-websocket published_release.mjs --bin BUILD/bin
//          --model MODEL.glb [--artifacts DIR] [--name props/box] [--frames 8]
//          [--resolution 512] [--layout octahedral]
import { spawn, spawnSync } from 'node:child_process';
import { mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

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

function fail(step, detail) {
  console.error(`published_release: ${step} failed: ${detail}`);
  process.exitCode = 1;
}

// Starts the server; resolves to {child, address} once it prints its address.
function startServer(data) {
  const child = spawn(join(bin, 'impostor-server'), ['--listen', '127.0.0.1:0', '--data', data, '--local-workers', '1',
    '--log-level', 'info'], { stdio: ['ignore', 'pipe', 'pipe'], detached: true });
  let log = '';
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`no "listening on" line in 60 s:\n${log.slice(-3000)}`)), 60000);
    const onData = (d) => {
      log += d;
      const m = log.match(/impostor-server listening on (\S+)/);
      if (m) {
        clearTimeout(timer);
        resolve({ child, address: m[1], log: () => log });
      }
    };
    child.stdout.on('data', onData);
    child.stderr.on('data', onData);
    child.on('exit', (code) => reject(new Error(`impostor-server exited with ${code}:\n${log.slice(-3000)}`)));
  });
}

// SIGTERM to the server's process group (its local workers with it), then waits.
async function stopServer(server) {
  const exited = new Promise((r) => server.child.once('exit', r));
  try {
    process.kill(-server.child.pid, 'SIGTERM');
  } catch {
    return;
  }
  const timer = setTimeout(() => {
    try { process.kill(-server.child.pid, 'SIGKILL'); } catch { /* gone */ }
  }, 20000);
  await exited;
  clearTimeout(timer);
}

const tmp = mkdtempSync(join(tmpdir(), 'impostor-three-published-'));
let server = null;
try {
  server = await startServer(join(tmp, 'data'));
  const run = (step, argv) => {
    const r = spawnSync(join(bin, 'impostor'), argv, { encoding: 'utf8', timeout: 300000 });
    if (r.status !== 0) throw new Error(`${step}: exit ${r.status}\n${r.stderr}\n${r.stdout}`);
    return r.stdout;
  };
  // The mesh baked twice: PNG maps, and KTX2 (UASTC with the baker's mips).
  const bake = (dir, extra) => {
    run('impostor bake', ['bake', model, '--out', join(tmp, dir), '--server', server.address, '--layout',
      arg('layout', 'octahedral'), '--frames', arg('frames', '8'), '--resolution', arg('resolution', '512'), '--quiet', ...extra]);
    return JSON.parse(readFileSync(join(tmp, dir, 'manifest.json'), 'utf8')).cache_key;
  };
  const key = bake('result', []);
  const ktx2Key = bake('result_ktx2', ['--texture-format', 'ktx2', '--quality-views', '0']);
  console.log(run('impostor publish', ['publish', `${name}=${key}`, `${name}-ktx2=${ktx2Key}`, '--channel', channel,
    '--out', join(tmp, 'release'), '--server', server.address]).trim());
  await stopServer(server);
  server = null;
  const browser = spawnSync(process.execPath, ['--experimental-websocket', join(here, 'browser_test.mjs'),
    '--release', join(tmp, 'release'), '--asset', name, '--ktx2-asset', `${name}-ktx2`, '--channel', channel,
    '--reference-glb', model,
    ...(arg('artifacts') ? ['--artifacts', arg('artifacts')] : [])], { stdio: 'inherit', timeout: 480000 });
  process.exitCode = browser.status ?? 1;
} catch (e) {
  fail('set-up', e.message);
} finally {
  if (server) await stopServer(server);
  rmSync(tmp, { recursive: true, force: true });
}
