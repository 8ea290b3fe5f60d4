// Shared set-up of the web package's node tests: a synthetic baked result
// published as a release tree in a temporary directory (or the release the
// real `impostor publish` made, from IMPOSTOR_RELEASE_DIR), mirrors serving
// it, an in-memory Cache Storage and a fetch that records what it was asked.
import { webcrypto } from 'node:crypto';
import { mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { publishRelease } from './publish_release.mjs';
import { startStaticServer } from './static_server.mjs';
import { writeSyntheticResult } from './synthetic_result.mjs';

// Node 18 (Debian 12's) has WebCrypto only as node:crypto's webcrypto, as a
// page has it as globalThis.crypto.
if (!globalThis.crypto) globalThis.crypto = webcrypto;

export const ASSET = 'props/box';
export const CHANNEL = 'nightly';

// {root, result (dir of the baked result), manifest, catalog, cleanup()}.
export function makeRelease({ signKeyPem = null, assets = null } = {}) {
  const dir = mkdtempSync(join(tmpdir(), 'impostor-web-package-'));
  const result = join(dir, 'box');
  const manifest = writeSyntheticResult(result, { frames: 4, resolution: 128 });
  const root = join(dir, 'release');
  const { catalogSha256 } = publishRelease({
    out: root, channel: CHANNEL, assets: assets || [{ name: ASSET, dir: result }], signKeyPem, now: 1764633600,
  });
  const catalog = JSON.parse(readFileSync(join(root, 'v1/catalogs/sha256', catalogSha256.slice(0, 2), catalogSha256), 'utf8'));
  return { root, result, manifest, catalog, catalogSha256, cleanup: () => rmSync(dir, { recursive: true, force: true }) };
}

// A mirror of `root` at /mirror (so the base URL has a path, as a CDN's does).
export function startMirror(root, options = {}) {
  return startStaticServer([{ prefix: '/mirror/', dir: root }], options).then((s) => ({ ...s, base: `${s.url}/mirror` }));
}

export class MemoryCacheStorage {
  constructor() { this.caches = new Map(); }
  async open(name) {
    if (!this.caches.has(name)) this.caches.set(name, new MemoryCache());
    return this.caches.get(name);
  }
}

class MemoryCache {
  constructor() { this.entries = new Map(); }
  async match(key) {
    const e = this.entries.get(String(key));
    return e ? new Response(e.body.slice(), { headers: e.headers }) : undefined;
  }
  async put(key, response) {
    this.entries.set(String(key), { body: new Uint8Array(await response.arrayBuffer()), headers: Object.fromEntries(response.headers) });
  }
  async delete(key) { return this.entries.delete(String(key)); }
}

// fetch that records [{url, cache}] of every call.
export function recordingFetch() {
  const calls = [];
  const f = (url, init = {}) => {
    calls.push({ url: String(url), cache: init.cache });
    return fetch(url, init);
  };
  f.calls = calls;
  return f;
}

export const blobRequests = (server) => server.requests.filter((r) => r.path.includes('/v1/blobs/')).map((r) => r.path);
