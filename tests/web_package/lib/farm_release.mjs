// A published release made by this build's farm, for the browser tests and
// the web forest bench: starts impostor-server with one local worker (port
// 0, a data directory under `dir`), bakes models with `impostor bake`,
// publishes them with `impostor publish NAME=KEY ... --channel C --out DIR`
// and stops the server. Nothing is left behind but what is under `dir`.
import { spawn } from 'node:child_process';
import { mkdirSync, readFileSync } from 'node:fs';
import { join } from 'node:path';

// Starts the server; resolves to {child, address, log()} once it prints its
// address (60 s at most). Its TMPDIR (and its local workers' scratch) is
// DATA.tmp, so even a killed worker leaves nothing in /tmp.
export function startFarm(bin, data) {
  mkdirSync(`${data}.tmp`, { recursive: true });
  const child = spawn(join(bin, 'impostor-server'), ['--listen', '127.0.0.1:0', '--data', data, '--local-workers', '1',
    '--log-level', 'info'], { stdio: ['ignore', 'pipe', 'pipe'], detached: true, env: { ...process.env, TMPDIR: `${data}.tmp` } });
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
    child.on('exit', (code) => {
      clearTimeout(timer);
      reject(new Error(`impostor-server exited with ${code}:\n${log.slice(-3000)}`));
    });
  });
}

// SIGTERM to the server's process group (its local workers with it), then
// waits; SIGKILL after 20 s.
export async function stopFarm(farm) {
  if (farm.child.exitCode !== null || farm.child.signalCode !== null) return;
  const exited = new Promise((r) => farm.child.once('exit', r));
  try {
    process.kill(-farm.child.pid, 'SIGTERM');
  } catch {
    return;
  }
  const timer = setTimeout(() => {
    try { process.kill(-farm.child.pid, 'SIGKILL'); } catch { /* gone */ }
  }, 20000);
  await exited;
  clearTimeout(timer);
}

// Runs the CLI (asynchronously: the server's pipes keep being read);
// resolves to its stdout, or rejects naming the step with its output.
export function impostorCli(bin, step, argv, timeoutMs = 300000) {
  return new Promise((resolve, reject) => {
    const child = spawn(join(bin, 'impostor'), argv, { stdio: ['ignore', 'pipe', 'pipe'], timeout: timeoutMs });
    let stdout = '', stderr = '';
    child.stdout.on('data', (d) => { stdout += d; });
    child.stderr.on('data', (d) => { stderr += d; });
    child.on('error', (e) => reject(new Error(`${step}: ${e.message}`)));
    child.on('close', (code, signal) => {
      if (code === 0) resolve(stdout);
      else reject(new Error(`${step}: exit ${code ?? signal}\n${stderr.slice(-3000)}\n${stdout.slice(-3000)}`));
    });
  });
}

// Bakes `model` into `out` on the farm at `address`; resolves to its cache
// key. options: {layout ('octahedral'), frames (8), resolution (512),
// extra: more CLI arguments}.
export async function bake(bin, address, model, out, { layout = 'octahedral', frames = 8, resolution = 512, extra = [] } = {}) {
  await impostorCli(bin, 'impostor bake', ['bake', model, '--out', out, '--server', address, '--layout', layout,
    '--frames', String(frames), '--resolution', String(resolution), '--quiet', ...extra]);
  return JSON.parse(readFileSync(join(out, 'manifest.json'), 'utf8')).cache_key;
}

// Publishes {name: key} as `channel` into the release tree `out`; resolves
// to the CLI's report.
export async function publish(bin, address, assets, channel, out) {
  return (await impostorCli(bin, 'impostor publish', ['publish', ...Object.entries(assets).map(([n, k]) => `${n}=${k}`),
    '--channel', channel, '--out', out, '--server', address])).trim();
}

// The whole round: a farm in `dir`/data, each of `models` ({name, model,
// options}) baked into `dir`/baked/<i>, all published as `channel` into
// `dir`/release, the farm stopped. Resolves to {release, keys: {name: key},
// report}.
export async function publishWithFarm({ bin, dir, models, channel = 'nightly' }) {
  const farm = await startFarm(bin, join(dir, 'data'));
  try {
    const keys = {};
    for (const [i, m] of models.entries()) keys[m.name] = await bake(bin, farm.address, m.model, join(dir, 'baked', String(i)), m.options);
    const release = join(dir, 'release');
    const report = await publish(bin, farm.address, keys, channel, release);
    return { release, keys, report };
  } finally {
    await stopFarm(farm);
  }
}

// The catalog a channel of a release tree names.
export function catalogOf(root, channel) {
  const pointer = JSON.parse(readFileSync(join(root, 'v1', 'channels', `${channel}.json`), 'utf8'));
  const hex = pointer.catalog.sha256;
  return JSON.parse(readFileSync(join(root, 'v1', 'catalogs', 'sha256', hex.slice(0, 2), hex), 'utf8'));
}
