// A release's channel pointer and catalog (client/delivery/release_format.md)
// read back from a mirror: untrusted bytes, every field checked, the first
// problem reported as a TypeError naming where the bytes came from and the
// field ("assets["trees/oak"].files[2].sha256 must be 64 lowercase hex
// characters"). The same checks as the C++ SDK's ParseCatalog and
// ParseChannel (client/delivery/catalog.cc). Pure functions.
import {
  CATALOG_SCHEMA_VERSION, CHANNEL_SCHEMA_VERSION, isSha256Hex, mediaTypeForFile, validateAssetName,
  validateChannelName,
} from './release_paths.js';

const MANIFEST_NAME = 'manifest.json';
const MAX_FILES_PER_ASSET = 4096;
const MAX_FILE_NAME_LENGTH = 255;

// A schema_version newer than this reader knows: the caller should update
// the package (the C++ SDK answers FAILED_PRECONDITION for it).
export class ImpostorSchemaError extends Error {
  constructor(message) {
    super(message);
    this.name = 'ImpostorSchemaError';
  }
}

class Reader {
  constructor(source) { this.source = source; }
  fail(path, why) { throw new TypeError(`${this.source}: ${path} ${why}`); }
  field(object, key, path, type) {
    if (object === null || typeof object !== 'object' || Array.isArray(object)) this.fail(path || '(document)', 'must be an object');
    if (!Object.prototype.hasOwnProperty.call(object, key)) this.fail(path + key, 'is missing');
    const v = object[key];
    const ok = type === 'count' ? Number.isSafeInteger(v) && v >= 0
      : type === 'array' ? Array.isArray(v)
        : type === 'object' ? v !== null && typeof v === 'object' && !Array.isArray(v)
          : typeof v === type;
    if (!ok) {
      this.fail(path + key, `must be ${{ count: 'a whole number >= 0', array: 'an array', object: 'an object', string: 'a string' }[type]}`);
    }
    return v;
  }
  string(o, key, path) { return this.field(o, key, path, 'string'); }
  count(o, key, path) { return this.field(o, key, path, 'count'); }
  hex(value, path) { if (!isSha256Hex(value)) this.fail(path, 'must be 64 lowercase hex characters'); }
}

function parseJson(text, source, what) {
  let doc;
  try {
    doc = JSON.parse(text);
  } catch {
    doc = null;
  }
  if (doc === null || typeof doc !== 'object' || Array.isArray(doc)) {
    throw new TypeError(`${source}: not a JSON object (a ${what} was expected; an HTML error page?)`);
  }
  return doc;
}

function checkSchema(r, doc, schema, known, source) {
  const name = r.string(doc, 'schema', '');
  if (name !== schema) r.fail('schema', `is "${name.slice(0, 40)}", expected "${schema}"`);
  const version = r.count(doc, 'schema_version', '');
  if (version > known) {
    throw new ImpostorSchemaError(`${source}: schema_version ${version} is newer than this reader's (${known}); update impostor-three`);
  }
  if (version < 1) throw new TypeError(`${source}: schema_version must be >= 1`);
  return version;
}

// text: the channel file's UTF-8 text. Returns {schemaVersion, channel,
// catalog: {sha256, sizeBytes}, publishedAt, signature: {algorithm, keyId,
// value} | null}.
export function parseChannel(text, source) {
  const doc = parseJson(text, source, 'channel file');
  const r = new Reader(source);
  const schemaVersion = checkSchema(r, doc, 'impostor-channel', CHANNEL_SCHEMA_VERSION, source);
  const channel = r.string(doc, 'channel', '');
  const catalog = r.field(doc, 'catalog', '', 'object');
  const sha256 = r.string(catalog, 'sha256', 'catalog.');
  r.hex(sha256, 'catalog.sha256');
  const sizeBytes = r.count(catalog, 'size_bytes', 'catalog.');
  const publishedAt = 'published_at' in doc ? r.string(doc, 'published_at', '') : '';
  let signature = null;
  if ('signature' in doc) {
    const sig = r.field(doc, 'signature', '', 'object');
    signature = {
      algorithm: r.string(sig, 'algorithm', 'signature.'),
      keyId: r.string(sig, 'key_id', 'signature.'),
      value: r.string(sig, 'value', 'signature.'),
    };
  }
  validateChannelName(channel, `${source}: channel`);
  return { schemaVersion, channel, catalog: { sha256, sizeBytes }, publishedAt, signature };
}

function parseFile(r, f, fpath) {
  const file = {
    name: r.string(f, 'name', fpath),
    semantic: r.string(f, 'semantic', fpath),
    sha256: r.string(f, 'sha256', fpath),
    sizeBytes: r.count(f, 'size_bytes', fpath),
  };
  r.hex(file.sha256, `${fpath}sha256`);
  file.mediaType = 'media_type' in f ? r.string(f, 'media_type', fpath) : mediaTypeForFile(file.name);
  file.width = 'width' in f ? r.count(f, 'width', fpath) : 0;
  file.height = 'height' in f ? r.count(f, 'height', fpath) : 0;
  file.format = 'format' in f ? r.string(f, 'format', fpath) : '';
  const n = file.name;
  if (n === '' || n.length > MAX_FILE_NAME_LENGTH || n === '.' || n === '..' || /[/\\\0]/.test(n) || n[0] === '.') {
    r.fail(`${fpath}name`, 'must be a plain file name (no path, not hidden, at most 255 characters)');
  }
  return file;
}

// text: the catalog file's UTF-8 text. Returns {schemaVersion, createdAt,
// bakerVersion, assets: Map(name -> {name, cacheKey, product, layout,
// frames, resolution, bakerVersion, manifest: {sha256, sizeBytes}, files:
// [{name, semantic, sha256, sizeBytes, mediaType, width, height,
// format}]})}.
export function parseCatalog(text, source) {
  const doc = parseJson(text, source, 'catalog');
  const r = new Reader(source);
  const schemaVersion = checkSchema(r, doc, 'impostor-catalog', CATALOG_SCHEMA_VERSION, source);
  const catalog = {
    schemaVersion,
    createdAt: r.string(doc, 'created_at', ''),
    bakerVersion: r.string(doc, 'baker_version', ''),
    assets: new Map(),
  };
  const assets = r.field(doc, 'assets', '', 'object');
  for (const [name, a] of Object.entries(assets)) {
    const path = `assets[${JSON.stringify(name.slice(0, 80))}].`;
    validateAssetName(name, `${source}: asset name`);
    const asset = {
      name,
      cacheKey: r.string(a, 'cache_key', path),
      product: r.string(a, 'product', path),
      layout: r.string(a, 'layout', path),
      frames: r.count(a, 'frames', path),
      resolution: r.count(a, 'resolution', path),
      bakerVersion: a && 'baker_version' in a ? r.string(a, 'baker_version', path) : '',
      manifest: null,
      files: [],
    };
    r.hex(asset.cacheKey, `${path}cache_key`);
    const manifest = r.field(a, 'manifest', path, 'object');
    asset.manifest = { sha256: r.string(manifest, 'sha256', `${path}manifest.`), sizeBytes: r.count(manifest, 'size_bytes', `${path}manifest.`) };
    r.hex(asset.manifest.sha256, `${path}manifest.sha256`);
    const files = r.field(a, 'files', path, 'array');
    if (files.length > MAX_FILES_PER_ASSET) r.fail(`${path}files`, `lists ${files.length} files; the limit is ${MAX_FILES_PER_ASSET}`);
    const names = new Set();
    let hasManifest = false;
    files.forEach((f, i) => {
      const fpath = `${path}files[${i}].`;
      const file = parseFile(r, f, fpath);
      if (names.has(file.name)) r.fail(`${fpath}name`, `"${file.name}" is listed twice`);
      names.add(file.name);
      if (file.name === MANIFEST_NAME) {
        hasManifest = true;
        if (file.sha256 !== asset.manifest.sha256 || file.sizeBytes !== asset.manifest.sizeBytes) {
          r.fail(`${fpath}sha256`, "differs from the asset's manifest digest");
        }
      }
      asset.files.push(file);
    });
    if (!hasManifest) r.fail(`${path}files`, 'must list manifest.json');
    catalog.assets.set(name, asset);
  }
  return catalog;
}
