// Reads a published release (client/delivery/release_format.md) from one or
// more mirrors: the channel file (fetched with `cache: 'no-cache'`, so a
// publish shows up at once), the catalog it names and the files of an asset,
// each verified against its SHA-256 with WebCrypto before anything uses it.
// Verified catalogs and blobs are kept in the browser's Cache Storage
// (`caches.open('impostor-blobs-v1')`), keyed by their release path under a
// fixed origin (CACHE_KEY_ORIGIN + "v1/blobs/sha256/<hh>/<hex>"), so the same
// blob from any mirror is one entry and a second visit downloads nothing; a
// cached copy is verified again when read (and dropped if it is wrong).
//
// Sources and order: Cache Storage, then the mirrors in the order given. A
// mirror is left for the next at an HTTP error, a network error, a body that
// stalls for `stallTimeoutMs`, a size other than the catalog's or a digest
// mismatch; nothing unverified is ever returned. Two requests for one digest
// share one download. The last channel file read is kept too, so a page that
// has everything cached still opens offline.
//
// No three.js here: this module runs in browsers, workers and Node.js (give
// `cacheStorage: null` or an object with the CacheStorage interface where
// there is no `caches`). One ReleaseClient may serve any number of
// concurrent calls.
import { parseCatalog, parseChannel } from './catalog.js';
import { blobPath, catalogPath, channelPath, joinUrl, validateAssetName, validateChannelName } from './release_paths.js';

export const DEFAULT_CACHE_NAME = 'impostor-blobs-v1';
// Cache Storage keys must be http(s) URLs; .invalid is never resolved.
export const CACHE_KEY_ORIGIN = 'https://impostor-release.invalid/';
const DEFAULT_STALL_TIMEOUT_MS = 15000;
const MAX_CHANNEL_BYTES = 64 * 1024;  // a channel file is a few hundred bytes

// Bytes whose SHA-256 is not the one their name promised.
export class ImpostorIntegrityError extends Error {
  constructor({ file, url, expected, actual }) {
    super(`${file}: SHA-256 mismatch from ${url}: expected ${expected}, got ${actual}`);
    this.name = 'ImpostorIntegrityError';
    Object.assign(this, { file, url, expected, actual });
  }
}

// No source gave verified bytes. `attempts` lists each source's failure
// ({url, error}); the message names the file, its digest and every failure.
export class ImpostorFetchError extends Error {
  constructor({ file, sha256, attempts }) {
    const why = attempts.length ? attempts.map((a) => a.error.message).join('; ') : 'no mirror is set (setMirror)';
    super(`${file}${sha256 ? ` (sha256 ${sha256})` : ''}: no mirror served it verified: ${why}`);
    this.name = 'ImpostorFetchError';
    Object.assign(this, { file, sha256, attempts });
  }
}

const HEX = Array.from({ length: 256 }, (_, i) => i.toString(16).padStart(2, '0'));

export function toHex(bytes) {
  const b = bytes instanceof Uint8Array ? bytes : new Uint8Array(bytes);
  let s = '';
  for (let i = 0; i < b.length; ++i) s += HEX[b[i]];
  return s;
}

export async function sha256Hex(subtle, bytes) {
  return toHex(await subtle.digest('SHA-256', bytes));
}

function base64ToBytes(text) {
  const bin = atob(text.replace(/\s+/g, ''));
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; ++i) out[i] = bin.charCodeAt(i);
  return out;
}

// The raw 32-byte Ed25519 public key from raw bytes, base64 of them or a PEM
// SubjectPublicKeyInfo (`openssl pkey -pubout`).
export function ed25519RawKey(key) {
  let raw = key;
  if (typeof key === 'string') {
    const pem = key.match(/-----BEGIN PUBLIC KEY-----([\s\S]*?)-----END PUBLIC KEY-----/);
    raw = base64ToBytes(pem ? pem[1] : key);
  }
  raw = raw instanceof Uint8Array ? raw : new Uint8Array(raw);
  // SPKI of an Ed25519 key: a 12-byte header (OID 1.3.101.112) + 32 bytes.
  if (raw.length === 44 && raw[0] === 0x30 && raw[8] === 0x70) raw = raw.subarray(12);
  if (raw.length !== 32) throw new TypeError(`public key: ${raw.length} bytes; an Ed25519 key is 32 (raw) or a PEM public key`);
  return raw;
}

// A timer that rejects `stalled` (and aborts `controller`) once `ms` pass
// without arm() being called.
function stallWatch(ms, controller, what) {
  let timer = null;
  let fail = null;
  const stalled = new Promise((_, reject) => { fail = reject; });
  stalled.catch(() => {});  // raced by the caller; never unhandled
  const arm = () => {
    clearTimeout(timer);
    timer = setTimeout(() => {
      fail(new Error(`${what()}: stalled, no bytes for ${ms} ms`));
      controller.abort();
    }, ms);
  };
  arm();
  return { stalled, arm, stop: () => clearTimeout(timer) };
}

export class ReleaseClient {
  // options: {mirrors: string[], channel: string, fetch, subtle, cacheStorage
  // (null: no Cache Storage), cacheName, publicKey (raw 32 bytes, base64 or
  // PEM: refuse catalogs without a valid Ed25519 signature), stallTimeoutMs,
  // requestInit (merged into every fetch: credentials, headers), resolveUrl
  // (url -> url, e.g. a LoadingManager's resolveURL)}.
  constructor(options = {}) {
    this.mirrors = [...(options.mirrors || [])];
    this.channel = options.channel ?? null;
    this.fetch = options.fetch || ((...args) => globalThis.fetch(...args));
    this.subtle = options.subtle || (globalThis.crypto && globalThis.crypto.subtle);
    this.cacheStorage = options.cacheStorage === undefined ? (globalThis.caches ?? null) : options.cacheStorage;
    this.cacheName = options.cacheName || DEFAULT_CACHE_NAME;
    this.publicKey = options.publicKey ?? null;
    this.stallTimeoutMs = options.stallTimeoutMs ?? DEFAULT_STALL_TIMEOUT_MS;
    this.requestInit = options.requestInit || {};
    this.resolveUrl = options.resolveUrl || ((url) => url);
    this._inflight = new Map();  // release path -> Promise of a verified download
    this._resolved = null;       // Promise of the channel's catalog
    if (!this.subtle) throw new Error('WebCrypto (crypto.subtle) is not available: serve the page over https or from localhost');
  }

  setMirrors(mirrors) {
    this.mirrors = [...mirrors];
    this._resolved = null;
  }

  setChannel(channel) {
    this.channel = channel;
    this._resolved = null;
  }

  // Forgets the resolved channel: the next call reads the channel file again.
  refresh() {
    this._resolved = null;
  }

  async _cache() {
    if (!this.cacheStorage) return null;
    try {
      return await this.cacheStorage.open(this.cacheName);
    } catch {
      return null;  // e.g. an opaque origin: run without the cache
    }
  }

  // The channel's catalog: {channel (the pointer), channelSource ('network'
  // | 'cache'), channelUrl, catalog, catalogSha256, catalogBytes,
  // catalogSource}. Read once per client (refresh() reads again).
  resolveChannel() {
    if (!this._resolved) {
      this._resolved = this._resolveChannel();
      this._resolved.catch(() => { this._resolved = null; });
    }
    return this._resolved;
  }

  async _resolveChannel() {
    const channel = this.channel;
    if (channel === null || channel === undefined) throw new Error('no channel is set (setChannel)');
    validateChannelName(channel);
    const path = channelPath(channel);
    const cache = await this._cache();
    const attempts = [];
    let pointer = null, channelSource = 'network', channelUrl = '', text = null;
    for (const mirror of this.mirrors) {
      const url = this.resolveUrl(joinUrl(mirror, path));
      try {
        text = new TextDecoder().decode(await this._download(url, MAX_CHANNEL_BYTES, () => {}, 'no-cache'));
        pointer = parseChannel(text, url);
        if (pointer.channel !== channel) throw new Error(`${url}: names channel "${pointer.channel}", not "${channel}"`);
        channelUrl = url;
        break;
      } catch (e) {
        attempts.push({ url, error: e instanceof Error ? e : new Error(String(e)) });
        pointer = null;
      }
    }
    const key = CACHE_KEY_ORIGIN + path;
    if (pointer && cache) {
      await cache.put(key, new Response(text, { headers: { 'content-type': 'application/json' } })).catch(() => {});
    }
    if (!pointer && cache) {
      // Every mirror failed: the last channel file seen, if any (offline).
      const cached = await cache.match(key);
      if (cached) {
        pointer = parseChannel(await cached.text(), `${key} (Cache Storage)`);
        channelSource = 'cache';
        channelUrl = key;
      }
    }
    if (!pointer) throw new ImpostorFetchError({ file: `channel "${channel}"`, sha256: '', attempts });
    const fetched = await this.fetchVerified({
      file: `catalog of channel "${channel}"`, sha256: pointer.catalog.sha256, sizeBytes: pointer.catalog.sizeBytes,
      path: catalogPath(pointer.catalog.sha256),
    });
    if (this.publicKey !== null) await this._verifySignature(pointer, fetched.bytes, channelUrl);
    const catalog = parseCatalog(new TextDecoder().decode(fetched.bytes), fetched.url);
    return {
      channel: pointer, channelSource, channelUrl, catalog, catalogSha256: pointer.catalog.sha256,
      catalogBytes: fetched.bytes, catalogSource: fetched.source,
    };
  }

  async _verifySignature(pointer, catalogBytes, source) {
    const raw = ed25519RawKey(this.publicKey);
    const keyId = (await sha256Hex(this.subtle, raw)).slice(0, 16);
    const sig = pointer.signature;
    if (!sig) throw new Error(`${source}: the catalog is not signed, and a public key (${keyId}) was given`);
    if (sig.algorithm !== 'ed25519') throw new Error(`${source}: signature algorithm "${sig.algorithm}", expected "ed25519"`);
    if (sig.keyId !== keyId) throw new Error(`${source}: signed by key ${sig.keyId}, expected ${keyId}`);
    const key = await this.subtle.importKey('raw', raw, { name: 'Ed25519' }, false, ['verify']);
    let ok = false;
    try {
      ok = await this.subtle.verify({ name: 'Ed25519' }, key, base64ToBytes(sig.value), catalogBytes);
    } catch {
      ok = false;
    }
    if (!ok) throw new Error(`${source}: the catalog's Ed25519 signature does not verify with key ${keyId}`);
  }

  // One immutable file by digest: {bytes: Uint8Array, source: 'cache' |
  // 'network', url}. `path` is its release path (blobPath(sha256) by
  // default); `onBytes(n)` is called as bytes arrive from the network.
  // Rejects with ImpostorFetchError when no source has verified bytes.
  fetchVerified({ file, sha256, sizeBytes, path = blobPath(sha256), onBytes = () => {} }) {
    const key = `${path}`;
    let pending = this._inflight.get(key);
    if (!pending) {
      pending = this._fetchVerified({ file, sha256, sizeBytes, path, onBytes });
      this._inflight.set(key, pending);
      const forget = () => this._inflight.delete(key);
      pending.then(forget, forget);
    }
    return pending;
  }

  async _fetchVerified({ file, sha256, sizeBytes, path, onBytes }) {
    const cache = await this._cache();
    const key = CACHE_KEY_ORIGIN + path;
    if (cache) {
      const hit = await cache.match(key);
      if (hit) {
        const bytes = new Uint8Array(await hit.arrayBuffer());
        if (bytes.length === sizeBytes && (await sha256Hex(this.subtle, bytes)) === sha256) {
          return { bytes, source: 'cache', url: key };
        }
        await cache.delete(key);  // a damaged entry: fetch it again
      }
    }
    const attempts = [];
    for (const mirror of this.mirrors) {
      const url = this.resolveUrl(joinUrl(mirror, path));
      try {
        const bytes = await this._download(url, sizeBytes, onBytes, cache ? 'no-store' : 'default');
        if (bytes.length !== sizeBytes) {
          throw new Error(`${url}: ${bytes.length} bytes, the catalog says ${sizeBytes} (${file})`);
        }
        const actual = await sha256Hex(this.subtle, bytes);
        if (actual !== sha256) throw new ImpostorIntegrityError({ file, url, expected: sha256, actual });
        if (cache) {
          // A full quota only costs the next visit a download.
          await cache.put(key, new Response(bytes, {
            headers: { 'content-type': 'application/octet-stream', 'x-impostor-sha256': sha256 },
          })).catch(() => {});
        }
        return { bytes, source: 'network', url };
      } catch (e) {
        attempts.push({ url, error: e instanceof Error ? e : new Error(String(e)) });
      }
    }
    throw new ImpostorFetchError({ file, sha256, attempts });
  }

  async _download(url, sizeBytes, onBytes, cacheMode) {
    const controller = new AbortController();
    let received = 0;
    const watch = stallWatch(this.stallTimeoutMs, controller, () => `${url} after ${received} bytes`);
    try {
      const response = await Promise.race([
        this.fetch(url, { ...this.requestInit, cache: cacheMode, signal: controller.signal }), watch.stalled]);
      if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
      watch.arm();
      if (!response.body || !response.body.getReader) {
        const bytes = new Uint8Array(await Promise.race([response.arrayBuffer(), watch.stalled]));
        onBytes(bytes.length);
        return bytes;
      }
      const reader = response.body.getReader();
      const chunks = [];
      for (;;) {
        const { done, value } = await Promise.race([reader.read(), watch.stalled]);
        if (done) break;
        received += value.length;
        if (received > sizeBytes) {
          reader.cancel().catch(() => {});
          throw new Error(`${url}: more than the ${sizeBytes} bytes expected`);
        }
        chunks.push(value);
        onBytes(value.length);
        watch.arm();
      }
      const bytes = new Uint8Array(received);
      let at = 0;
      for (const c of chunks) {
        bytes.set(c, at);
        at += c.length;
      }
      return bytes;
    } finally {
      watch.stop();
    }
  }

  // Every file of asset `name` that `semantics` selects (all when omitted;
  // manifest.json always), verified: {name, cacheKey, entry (the catalog's),
  // manifest (parsed manifest.json), files: [{name, semantic, sha256,
  // sizeBytes, mediaType, format, bytes, source, url, verified: true}],
  // channel, catalogSha256}. `onProgress({loaded, total})` counts bytes
  // taken from the network against the selected files' total.
  async loadAsset(name, { semantics = null, onProgress = () => {} } = {}) {
    validateAssetName(name);
    const release = await this.resolveChannel();
    const entry = release.catalog.assets.get(name);
    if (!entry) {
      const names = [...release.catalog.assets.keys()];
      throw new Error(`asset "${name}" is not in channel "${this.channel}" (catalog ${release.catalogSha256.slice(0, 12)}); `
        + `it has ${names.length ? names.slice(0, 10).map((n) => `"${n}"`).join(', ') + (names.length > 10 ? ', ...' : '') : 'no assets'}`);
    }
    const manifestFile = entry.files.find((f) => f.name === 'manifest.json');
    const wanted = entry.files.filter((f) => f !== manifestFile && (!semantics || semantics.includes(f.semantic)));
    const total = [manifestFile, ...wanted].reduce((sum, f) => sum + f.sizeBytes, 0);
    let loaded = 0;
    const onBytes = (n) => {
      loaded += n;
      onProgress({ loaded, total, lengthComputable: true });
    };
    const get = (f) => this.fetchVerified({ file: `${name}/${f.name}`, sha256: f.sha256, sizeBytes: f.sizeBytes, onBytes })
      .then((r) => ({ ...f, bytes: r.bytes, source: r.source, url: r.url, verified: true }));
    const [manifestOut, ...files] = await Promise.all([get(manifestFile), ...wanted.map(get)]);
    let manifest;
    try {
      manifest = JSON.parse(new TextDecoder().decode(manifestOut.bytes));
    } catch (e) {
      throw new Error(`${name}/manifest.json: not JSON (${e.message})`);
    }
    if (manifest.cache_key !== undefined && manifest.cache_key !== entry.cacheKey) {
      throw new Error(`${name}/manifest.json: cache_key ${manifest.cache_key} differs from the catalog's ${entry.cacheKey}`);
    }
    for (const f of files) {
      const map = (manifest.maps || []).find((m) => m.file === f.name);
      const hash = map && map.digest && map.digest.hash;
      if (hash && hash !== f.sha256) {
        throw new Error(`${name}/${f.name}: the manifest's digest ${hash} differs from the catalog's ${f.sha256}`);
      }
    }
    return {
      name, cacheKey: entry.cacheKey, entry, manifest, files: [manifestOut, ...files], channel: release.channel,
      catalogSha256: release.catalogSha256,
    };
  }
}
