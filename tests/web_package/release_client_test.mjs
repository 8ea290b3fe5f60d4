// impostor-three's ReleaseClient against real HTTP mirrors (Node.js servers
// on port 0 serving a release tree): an asset resolved through the channel
// and catalog, every file verified, a flipped byte refused and the next
// mirror used, the other ways a mirror fails, Cache Storage on a second
// load, offline loads, one download per digest, signed catalogs.
// Run: node --test tests/web_package/release_client_test.mjs
import assert from 'node:assert/strict';
import { createHash, generateKeyPairSync } from 'node:crypto';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { after, before, describe, test } from 'node:test';
import {
  CACHE_KEY_ORIGIN, ImpostorFetchError, ImpostorIntegrityError, ReleaseClient, blobPath,
} from '../../packages/impostor-three/src/release/index.js';
import {
  ASSET, CHANNEL, MemoryCacheStorage, blobRequests, makeRelease, recordingFetch, startMirror,
} from './lib/fixtures.mjs';

const sha256 = (bytes) => createHash('sha256').update(bytes).digest('hex');
const DRAWN = ['albedo_alpha', 'normal_depth', 'orm'];

describe('ReleaseClient', () => {
  let release;
  const servers = [];
  const mirror = async (options) => {
    const m = await startMirror(release.root, options);
    servers.push(m);
    return m;
  };
  const entry = () => release.catalog.assets[ASSET];
  const file = (name) => entry().files.find((f) => f.name === name);
  const client = (mirrors, options = {}) => new ReleaseClient({
    mirrors: mirrors.map((m) => (typeof m === 'string' ? m : m.base)), channel: CHANNEL, cacheStorage: null, ...options,
  });

  before(() => { release = makeRelease(); });
  after(async () => {
    await Promise.all(servers.map((s) => s.close()));
    release.cleanup();
  });

  test('resolves an asset through the channel and catalog and verifies every file', async () => {
    const a = await mirror();
    const loaded = await client([a]).loadAsset(ASSET);
    assert.equal(loaded.cacheKey, release.manifest.cache_key);
    assert.equal(loaded.manifest.cache_key, release.manifest.cache_key);
    assert.equal(loaded.catalogSha256, sha256(readFileSync(join(release.root, 'v1/catalogs/sha256',
      loaded.catalogSha256.slice(0, 2), loaded.catalogSha256))));
    // Every file the release lists, the manifest first; each one's bytes are the result's.
    assert.deepEqual(loaded.files.map((f) => f.name).sort(), entry().files.map((f) => f.name).sort());
    assert.equal(loaded.files[0].name, 'manifest.json');
    for (const f of loaded.files) {
      const original = readFileSync(join(release.result, f.name));
      assert.equal(sha256(f.bytes), sha256(original), f.name);
      assert.equal(f.verified, true, f.name);
      assert.equal(f.source, 'network', f.name);
      assert.equal(f.url, `${a.base}/${blobPath(f.sha256)}`, f.name);
    }
    assert.ok(!entry().files.some((f) => f.semantic === 'contact_sheet'), 'the contact sheet is not published');
    // Only the selected semantics (and the manifest) are fetched.
    const b = await mirror();
    const some = await client([b]).loadAsset(ASSET, { semantics: ['albedo_alpha'] });
    assert.deepEqual(some.files.map((f) => f.name), ['manifest.json', 'albedo_alpha.png']);
    assert.equal(blobRequests(b).length, 2);
  });

  test('a flipped byte on the first mirror is refused and the next mirror used', async () => {
    const albedo = file('albedo_alpha.png');
    const bad = await mirror({ tamper: (p) => p.endsWith(albedo.sha256) });
    const good = await mirror();
    const cacheStorage = new MemoryCacheStorage();
    const loaded = await client([bad, good], { cacheStorage }).loadAsset(ASSET, { semantics: DRAWN });
    const got = loaded.files.find((f) => f.name === 'albedo_alpha.png');
    assert.equal(sha256(got.bytes), albedo.sha256);
    assert.equal(got.url, `${good.base}/${blobPath(albedo.sha256)}`);
    assert.ok(blobRequests(bad).some((p) => p.endsWith(albedo.sha256)), 'the bad mirror was asked first');
    assert.ok(blobRequests(good).some((p) => p.endsWith(albedo.sha256)), 'then the good one');
    assert.ok(!blobRequests(good).some((p) => p.endsWith(file('orm.png').sha256)), 'files the first mirror served well stay from it');
    // What went into the cache is the verified copy.
    const cache = await cacheStorage.open('impostor-blobs-v1');
    const cached = await cache.match(CACHE_KEY_ORIGIN + blobPath(albedo.sha256));
    assert.equal(sha256(new Uint8Array(await cached.arrayBuffer())), albedo.sha256);
  });

  test('a flipped byte on the only mirror rejects, naming the file and both digests', async () => {
    const albedo = file('albedo_alpha.png');
    const bad = await mirror({ tamper: (p) => p.endsWith(albedo.sha256) });
    const tampered = Buffer.from(readFileSync(join(release.result, 'albedo_alpha.png')));
    tampered[tampered.length >> 1] ^= 1;
    const error = await client([bad]).loadAsset(ASSET).then(() => null, (e) => e);
    assert.ok(error instanceof ImpostorFetchError, String(error));
    assert.match(error.message, /albedo_alpha\.png/);
    assert.ok(error.message.includes(albedo.sha256), error.message);
    assert.ok(error.message.includes(sha256(tampered)), error.message);
    assert.equal(error.attempts.length, 1);
    assert.ok(error.attempts[0].error instanceof ImpostorIntegrityError);
    assert.equal(error.attempts[0].error.expected, albedo.sha256);
    assert.equal(error.attempts[0].error.actual, sha256(tampered));
  });

  const failures = [
    { name: 'HTTP 500 for everything', options: { fail: () => 500 }, asked: true },
    { name: 'HTTP 404 for blobs', options: { fail: (p) => (p.includes('/v1/blobs/') ? 404 : 0) }, asked: true },
    // Only the channel file is broken: the blobs still come from the first mirror.
    { name: 'an HTML error page as the channel file', options: { fail: (p) => (p.includes('/channels/') ? 200 : 0) }, asked: true, goodChannelOnly: true },
    { name: 'a blob body that stalls', options: { stall: (p) => p.includes('/v1/blobs/') }, asked: true, stallTimeoutMs: 300 },
    { name: 'a channel file that stalls', options: { stall: (p) => p.includes('/channels/') }, asked: true, stallTimeoutMs: 300, goodChannelOnly: true },
    { name: 'a refused connection', closed: true, asked: false },
  ];
  for (const c of failures) {
    test(`the next mirror is used after ${c.name}`, async () => {
      const bad = await mirror(c.options);
      if (c.closed) await bad.close();
      const good = await mirror();
      const loaded = await client([bad, good], { stallTimeoutMs: c.stallTimeoutMs ?? 15000 }).loadAsset(ASSET, { semantics: DRAWN });
      assert.equal(loaded.cacheKey, release.manifest.cache_key, c.name);
      for (const f of loaded.files) assert.equal(sha256(f.bytes), f.sha256, `${c.name}: ${f.name}`);
      if (c.goodChannelOnly) {
        assert.ok(good.requests.some((r) => r.path.includes('/channels/')), `${c.name}: the channel came from the good mirror`);
        assert.equal(blobRequests(good).length, 0, `${c.name}: blobs stay with the first mirror`);
      } else {
        assert.ok(blobRequests(good).length >= 1, `${c.name}: the good mirror served blobs`);
      }
      if (c.asked) assert.ok(bad.requests.length >= 1, `${c.name}: the bad mirror was asked first`);
    });
  }

  test('a second load takes every blob and the catalog from Cache Storage; the channel file is asked with no-cache', async () => {
    const a = await mirror();
    const cacheStorage = new MemoryCacheStorage();
    const first = await client([a], { cacheStorage }).loadAsset(ASSET, { semantics: DRAWN });
    assert.ok(first.files.every((f) => f.source === 'network'));
    const before = a.requests.length;
    const f = recordingFetch();
    const second = await client([a], { cacheStorage, fetch: f }).loadAsset(ASSET, { semantics: DRAWN });
    const paths = a.requests.slice(before).map((r) => r.path);
    assert.deepEqual(paths, [`/mirror/v1/channels/${CHANNEL}.json`], 'only the channel file went to the network');
    assert.deepEqual(f.calls.map((c) => c.cache), ['no-cache']);
    assert.ok(second.files.every((x) => x.source === 'cache' && x.verified), JSON.stringify(second.files.map((x) => x.source)));
    assert.deepEqual(second.files.map((x) => x.sha256), first.files.map((x) => x.sha256));
  });

  test('a damaged Cache Storage entry is dropped and downloaded again', async () => {
    const a = await mirror();
    const cacheStorage = new MemoryCacheStorage();
    await client([a], { cacheStorage }).loadAsset(ASSET, { semantics: DRAWN });
    const orm = file('orm.png');
    const cache = await cacheStorage.open('impostor-blobs-v1');
    const key = CACHE_KEY_ORIGIN + blobPath(orm.sha256);
    cache.entries.get(key).body[10] ^= 0xff;
    const again = await client([a], { cacheStorage }).loadAsset(ASSET, { semantics: DRAWN });
    const got = again.files.find((x) => x.name === 'orm.png');
    assert.equal(got.source, 'network');
    assert.equal(sha256(got.bytes), orm.sha256);
    assert.equal(sha256(new Uint8Array(await (await cache.match(key)).arrayBuffer())), orm.sha256, 'the cache holds the good copy again');
  });

  test('with every mirror down, the last channel file and the cached files still load', async () => {
    const a = await mirror();
    const cacheStorage = new MemoryCacheStorage();
    await client([a], { cacheStorage }).loadAsset(ASSET, { semantics: DRAWN });
    const down = await mirror({ fail: () => 503 });
    const c = client([down], { cacheStorage });
    const loaded = await c.loadAsset(ASSET, { semantics: DRAWN });
    assert.ok(loaded.files.every((f) => f.source === 'cache'));
    assert.equal((await c.resolveChannel()).channelSource, 'cache');
    // Without a cache there is nothing to fall back on.
    const error = await client([down]).loadAsset(ASSET).then(() => null, (e) => e);
    assert.ok(error instanceof ImpostorFetchError);
    assert.match(error.message, /channel "nightly".*HTTP 503/);
  });

  test('concurrent loads download each blob once', async () => {
    const twice = makeRelease({ assets: null });
    const a = await startMirror(twice.root);
    servers.push(a);
    const c = new ReleaseClient({ mirrors: [a.base], channel: CHANNEL, cacheStorage: null });
    await Promise.all([c.loadAsset(ASSET), c.loadAsset(ASSET), c.loadAsset(ASSET)]);
    const blobs = blobRequests(a);
    assert.equal(blobs.length, new Set(blobs).size, `repeated downloads: ${blobs.join(', ')}`);
    assert.equal(a.requests.filter((r) => r.path.includes('/channels/')).length, 1, 'one channel read per client');
    twice.cleanup();
  });

  test('a catalog whose bytes do not match the channel is refused', async () => {
    const bad = await mirror({ tamper: (p) => p.includes('/v1/catalogs/') });
    const error = await client([bad]).loadAsset(ASSET).then(() => null, (e) => e);
    assert.ok(error instanceof ImpostorFetchError, String(error));
    assert.match(error.message, /catalog of channel "nightly".*SHA-256 mismatch/);
  });

  test('an asset the catalog does not list is refused, naming those it has', async () => {
    const a = await mirror();
    await assert.rejects(client([a]).loadAsset('props/nope'), /asset "props\/nope" is not in channel "nightly".*"props\/box"/);
    await assert.rejects(client([a]).loadAsset('../etc'), /asset name "\.\.\/etc"/);
    await assert.rejects(new ReleaseClient({ mirrors: [a.base], channel: 'bad name', cacheStorage: null }).loadAsset(ASSET),
      /channel "bad name": must match/);
  });
});

describe('ReleaseClient with a public key', () => {
  const { privateKey, publicKey } = generateKeyPairSync('ed25519');
  const other = generateKeyPairSync('ed25519').publicKey;
  const pem = (k) => k.export({ format: 'pem', type: 'spki' });
  let signed, unsigned;
  const servers = [];
  before(() => {
    signed = makeRelease({ signKeyPem: privateKey.export({ format: 'pem', type: 'pkcs8' }) });
    unsigned = makeRelease();
  });
  after(async () => {
    await Promise.all(servers.map((s) => s.close()));
    signed.cleanup();
    unsigned.cleanup();
  });
  const load = async (root, key, options = {}) => {
    const m = await startMirror(root, options);
    servers.push(m);
    return new ReleaseClient({ mirrors: [m.base], channel: CHANNEL, cacheStorage: null, publicKey: key }).loadAsset(ASSET);
  };

  const cases = [
    { name: 'the signing key (PEM) accepts', root: () => signed.root, key: () => pem(publicKey), want: null },
    { name: 'the signing key (raw bytes) accepts', root: () => signed.root, key: () => publicKey.export({ format: 'der', type: 'spki' }).subarray(12), want: null },
    { name: 'another key refuses', root: () => signed.root, key: () => pem(other), want: /signed by key [0-9a-f]{16}, expected [0-9a-f]{16}/ },
    { name: 'an unsigned catalog refuses', root: () => unsigned.root, key: () => pem(publicKey), want: /the catalog is not signed/ },
  ];
  for (const c of cases) {
    test(c.name, async () => {
      const outcome = await load(c.root(), c.key()).then(() => null, (e) => e);
      if (c.want === null) assert.equal(outcome, null, String(outcome));
      else assert.match(String(outcome && outcome.message), c.want);
    });
  }

  test('a signature that does not verify refuses', async () => {
    const channelFile = join(signed.root, `v1/channels/${CHANNEL}.json`);
    const text = readFileSync(channelFile, 'utf8');
    const pointer = JSON.parse(text);
    const sig = Buffer.from(pointer.signature.value, 'base64');
    sig[5] ^= 1;
    const forged = JSON.stringify({ ...pointer, signature: { ...pointer.signature, value: sig.toString('base64') } });
    const m = await startMirror(signed.root);
    servers.push(m);
    const f = (url, init) => (String(url).endsWith(`${CHANNEL}.json`)
      ? Promise.resolve(new Response(forged, { status: 200 })) : fetch(url, init));
    const c = new ReleaseClient({ mirrors: [m.base], channel: CHANNEL, cacheStorage: null, publicKey: pem(publicKey), fetch: f });
    await assert.rejects(c.loadAsset(ASSET), /Ed25519 signature does not verify/);
  });
});
