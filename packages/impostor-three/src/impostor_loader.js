// ImpostorLoader: a three.js Loader for baked impostors published as a
// release (client/delivery/release_format.md):
//
//   const loader = new ImpostorLoader(manager)
//     .setMirror('https://cdn.example.com/impostors')
//     .setChannel('nightly');
//   const oak = await loader.loadAsync('trees/oak');
//   scene.add(new InstancedImpostorMesh(oak, 10000));
//
// load(name, onLoad, onProgress, onError) resolves the asset name through
// the channel file and its catalog, fetches the files it draws (manifest,
// albedo_alpha, normal_depth, orm) from the mirrors, verifies each one's
// SHA-256 before use and keeps it in Cache Storage (ReleaseClient), then
// decodes the maps into textures and resolves to an ImpostorAsset. The
// manager sees one item per asset. parseAsync(manifest, files) makes an
// ImpostorAsset from bytes the caller already has (a farm's result files).
import { Loader } from 'three';
import { ImpostorAsset } from './impostor_asset.js';
import { atlasLayout, productName } from './layout.js';
import { DEFAULT_CACHE_NAME, ImpostorIntegrityError, ReleaseClient, sha256Hex } from './release/release_client.js';
import { createRgbaKtx2Loader, decodeMap, defaultTranscoderPath, isKtx2File } from './textures.js';

// The maps the material reads, by semantic.
export const DRAWN_SEMANTICS = Object.freeze(['albedo_alpha', 'normal_depth', 'orm']);
// Products whose top-level maps are an atlas: a LOD chain's are its
// impostor level's.
const DRAWN_PRODUCTS = new Set(['atlas', 'lod-chain']);

export class ImpostorLoader extends Loader {
  constructor(manager) {
    super(manager);
    this.mirrors = [];
    this.channel = null;
    this.publicKey = null;
    this.cacheName = DEFAULT_CACHE_NAME;
    this.cacheStorage = undefined;  // undefined: globalThis.caches
    this.ktx2Loader = null;
    this.transcoderPath = '';
    this._ownKtx2Loader = null;
    this._client = null;
  }

  // The base URL of a release tree: the directory that holds v1/.
  setMirror(url) {
    return this.setMirrors([url]);
  }

  // Several mirrors, tried in this order for every file (on an HTTP error,
  // a stall, a wrong size or a digest mismatch the next is tried).
  setMirrors(urls) {
    if (!Array.isArray(urls) || urls.length === 0 || !urls.every((u) => typeof u === 'string' && u)) {
      throw new TypeError('setMirrors: want a non-empty array of base URLs');
    }
    this.mirrors = [...urls];
    this._client = null;
    return this;
  }

  setChannel(name) {
    this.channel = name;
    this._client = null;
    return this;
  }

  // An Ed25519 public key (raw 32 bytes, their base64, or PEM): catalogs
  // whose channel file carries no valid signature by it are refused.
  setPublicKey(key) {
    this.publicKey = key;
    this._client = null;
    return this;
  }

  // The Cache Storage cache verified files are kept in ('impostor-blobs-v1').
  setCacheName(name) {
    this.cacheName = name;
    this._client = null;
    return this;
  }

  // A CacheStorage (default: the global `caches`), or null to keep nothing.
  setCacheStorage(cacheStorage) {
    this.cacheStorage = cacheStorage;
    this._client = null;
    return this;
  }

  // A KTX2Loader of the page's own (transcoder path set, detectSupport
  // called): KTX2 maps are transcoded to what it chose.
  setKTX2Loader(ktx2Loader) {
    this.ktx2Loader = ktx2Loader;
    return this;
  }

  // Where three's Basis transcoder is served (examples/jsm/libs/basis/ of
  // the `three` package); by default resolved from the page's import map.
  setTranscoderPath(path) {
    this.transcoderPath = path;
    return this;
  }

  // Lets KTX2 maps transcode to a GPU format `renderer` supports (BC7, ASTC,
  // ETC2...); without it they are transcoded to RGBA8, exactly as stored.
  detectSupport(renderer) {
    this._ktx2().detectSupport(renderer);
    return this;
  }

  // The ReleaseClient behind the loader (channel, catalog, verified files).
  get client() {
    if (!this._client) {
      this._client = new ReleaseClient({
        mirrors: this.mirrors, channel: this.channel, publicKey: this.publicKey, cacheName: this.cacheName,
        cacheStorage: this.cacheStorage,
        requestInit: { headers: { ...this.requestHeader }, credentials: this.withCredentials ? 'include' : 'same-origin' },
        resolveUrl: (url) => this.manager.resolveURL(url),
      });
    }
    return this._client;
  }

  _ktx2() {
    if (this.ktx2Loader) return this.ktx2Loader;
    if (!this._ownKtx2Loader) {
      this._ownKtx2Loader = createRgbaKtx2Loader(this.manager, this.transcoderPath || defaultTranscoderPath());
    }
    return this._ownKtx2Loader;
  }

  load(name, onLoad, onProgress, onError) {
    const manager = this.manager;
    manager.itemStart(name);
    this._load(name, onProgress).then((asset) => {
      if (onLoad) onLoad(asset);
      manager.itemEnd(name);
    }, (error) => {
      if (onError) onError(error);
      else console.error(error);
      manager.itemError(name);
      manager.itemEnd(name);
    });
  }

  async _load(name, onProgress) {
    const client = this.client;
    const release = await client.resolveChannel();
    const entry = release.catalog.assets.get(name);
    if (entry && !DRAWN_PRODUCTS.has(entry.product)) {
      throw new Error(`asset "${name}" is a ${entry.product} product; ImpostorLoader draws atlases (and a LOD chain's impostor level)`);
    }
    // three's loaders report ProgressEvents (plain objects where there is no ProgressEvent, as in Node.js).
    const progress = !onProgress ? () => {}
      : typeof ProgressEvent === 'function' ? (p) => onProgress(new ProgressEvent('progress', p)) : onProgress;
    const loaded = await client.loadAsset(name, { semantics: DRAWN_SEMANTICS, onProgress: progress });
    const files = new Map(loaded.files.map((f) => [f.name, f.bytes]));
    const report = loaded.files.map(({ bytes, ...f }) => f);  // eslint-disable-line no-unused-vars
    return this._assetFrom(name, loaded.manifest, files, report,
      { channel: release.channel.channel, catalogSha256: release.catalogSha256 });
  }

  // An ImpostorAsset from a manifest (manifest.json, or the farm JSON API's
  // form of it) and the bytes of its maps: `files` maps a file name to an
  // ArrayBuffer or Uint8Array. Each map whose manifest entry carries a
  // digest is checked against it where WebCrypto is available (a page over
  // https or from localhost): a mismatch rejects with an
  // ImpostorIntegrityError; the report says `verified` per file.
  async parseAsync(manifest, files, name = manifest.cache_key || 'impostor') {
    const get = files instanceof Map ? (n) => files.get(n) : (n) => files[n];
    const subtle = globalThis.crypto && globalThis.crypto.subtle;
    const byName = new Map();
    const report = [];
    for (const map of manifest.maps || []) {
      if (!DRAWN_SEMANTICS.includes(map.semantic)) continue;
      const given = get(map.file);
      if (given === undefined) continue;
      const bytes = given instanceof Uint8Array ? given : new Uint8Array(given);
      const expected = (map.digest && map.digest.hash) || '';
      let verified = false;
      if (expected && subtle) {
        const actual = await sha256Hex(subtle, bytes);
        if (actual !== expected) throw new ImpostorIntegrityError({ file: `${name}/${map.file}`, url: '(given bytes)', expected, actual });
        verified = true;
      }
      byName.set(map.file, bytes);
      report.push({ name: map.file, semantic: map.semantic, sha256: expected, sizeBytes: bytes.length, verified,
        source: 'given', url: '' });
    }
    return this._assetFrom(name, manifest, byName, report, null);
  }

  async _assetFrom(name, manifest, files, report, catalog) {
    const product = productName(manifest.product);
    if (!DRAWN_PRODUCTS.has(product)) throw new Error(`${name}: a ${product} product; ImpostorLoader draws atlases`);
    const layout = atlasLayout(manifest);
    const mapOf = (semantic) => (manifest.maps || []).find((m) => m.semantic === semantic);
    const decode = async (semantic, required) => {
      const map = mapOf(semantic);
      if (!map || !files.has(map.file)) {
        if (required) throw new Error(`${name}: the result has no ${semantic} map to draw`);
        return null;
      }
      return decodeMap({
        bytes: files.get(map.file), file: map.file, semantic, manifest, layoutSide: layout.side,
        ktx2Loader: isKtx2File(map.file) ? this._ktx2() : null,
      });
    };
    const [albedo, normalDepth, orm] = await Promise.all([decode('albedo_alpha', true), decode('normal_depth', true),
      decode('orm', false)]);
    return new ImpostorAsset({ name, manifest, textures: { albedo, normalDepth, orm }, files: report, catalog });
  }

  // Ends the KTX2 transcoder workers this loader started.
  dispose() {
    if (this._ownKtx2Loader) this._ownKtx2Loader.dispose();
    this._ownKtx2Loader = null;
  }
}
