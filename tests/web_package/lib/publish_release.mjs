// A stand-in for `impostor publish` while it is being written: publishes
// baked result directories (manifest.json + files, as `impostor fetch` or
// the baker's --out writes them) as a release tree exactly as
// client/delivery/release_format.md lays it out: blobs and the catalog by
// SHA-256 under v1/, the catalog as canonical JSON (keys sorted, no
// whitespace), the channel file replaced by an atomic rename after every
// blob and the catalog are in place, the quality pass's files and the
// contact sheet left out unless includeQualityViews. The tests take the
// release root from IMPOSTOR_RELEASE_DIR (or --release) when the real
// publisher made one, and this script otherwise.
//
// CLI: node publish_release.mjs --out ROOT --channel NAME [--sign-key KEY.pem]
//        [--include-quality-views] NAME=RESULT_DIR...
import { createHash, createPrivateKey, createPublicKey, sign } from 'node:crypto';
import { existsSync, mkdirSync, readFileSync, renameSync, writeFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const QUALITY_SEMANTICS = new Set(['contact_sheet', 'quality_worst_view', 'quality_view_mesh', 'quality_view_impostor',
  'quality_views']);
const MEDIA_TYPES = { png: 'image/png', ktx2: 'image/ktx2', json: 'application/json', glb: 'model/gltf-binary',
  jpg: 'image/jpeg', jpeg: 'image/jpeg', webp: 'image/webp' };

const sha256 = (bytes) => createHash('sha256').update(bytes).digest('hex');
export const blobPath = (hex) => `v1/blobs/sha256/${hex.slice(0, 2)}/${hex}`;
export const catalogPath = (hex) => `v1/catalogs/sha256/${hex.slice(0, 2)}/${hex}`;
export const channelPath = (name) => `v1/channels/${name}.json`;

function mediaType(name) {
  const dot = name.lastIndexOf('.');
  return (dot >= 0 && MEDIA_TYPES[name.slice(dot + 1).toLowerCase()]) || 'application/octet-stream';
}

// nlohmann::json dump(): object keys sorted, no whitespace.
export function canonicalJson(value) {
  if (Array.isArray(value)) return `[${value.map(canonicalJson).join(',')}]`;
  if (value && typeof value === 'object') {
    return `{${Object.keys(value).sort().map((k) => `${JSON.stringify(k)}:${canonicalJson(value[k])}`).join(',')}}`;
  }
  return JSON.stringify(value);
}

function writeAtomic(path, bytes) {
  mkdirSync(dirname(path), { recursive: true });
  const tmp = `${path}.tmp-${process.pid}`;
  writeFileSync(tmp, bytes);
  renameSync(tmp, path);
}

function putBlob(root, path, bytes) {
  const file = join(root, path);
  if (!existsSync(file)) writeAtomic(file, bytes);
}

function rfc3339(seconds) {
  return new Date(seconds * 1000).toISOString().replace(/\.\d{3}Z$/, 'Z');
}

// assets: [{name, dir}]. Returns {catalogSha256, channelFile}.
export function publishRelease({ out, channel, assets, includeQualityViews = false, signKeyPem = null, now = null }) {
  const entries = {};
  const bakers = new Set();
  for (const { name, dir } of assets) {
    const manifestBytes = readFileSync(join(dir, 'manifest.json'));
    const manifest = JSON.parse(manifestBytes.toString('utf8'));
    const files = [];
    for (const map of manifest.maps) {
      if (!includeQualityViews && QUALITY_SEMANTICS.has(map.semantic)) continue;
      if (!map.file || map.file.includes('/') || map.file === 'manifest.json') {
        throw new Error(`${dir}: map file "${map.file}" is not a plain file name`);
      }
      const bytes = readFileSync(join(dir, map.file));
      const hex = sha256(bytes);
      if (map.digest && map.digest.hash && map.digest.hash !== hex) {
        throw new Error(`${dir}/${map.file}: SHA-256 ${hex}, the manifest says ${map.digest.hash}`);
      }
      putBlob(out, blobPath(hex), bytes);
      files.push({ name: map.file, semantic: map.semantic, sha256: hex, size_bytes: bytes.length,
        media_type: mediaType(map.file), width: map.width || 0, height: map.height || 0, format: map.format || '' });
    }
    const manifestHex = sha256(manifestBytes);
    putBlob(out, blobPath(manifestHex), manifestBytes);
    files.push({ name: 'manifest.json', semantic: 'manifest', sha256: manifestHex, size_bytes: manifestBytes.length,
      media_type: 'application/json', width: 0, height: 0, format: 'json' });
    bakers.add(manifest.baker_version || '');
    entries[name] = {
      cache_key: manifest.cache_key, product: manifest.product || 'atlas', layout: manifest.layout || 'octahedral',
      frames: manifest.frames, resolution: manifest.resolution, baker_version: manifest.baker_version || '',
      manifest: { sha256: manifestHex, size_bytes: manifestBytes.length }, files,
    };
  }
  const seconds = now ?? (process.env.SOURCE_DATE_EPOCH ? Number(process.env.SOURCE_DATE_EPOCH) : Math.floor(Date.now() / 1000));
  // The same assets as the channel's current catalog: reuse it (same digest).
  let catalogBytes = null;
  const channelFile = join(out, channelPath(channel));
  if (existsSync(channelFile)) {
    const current = JSON.parse(readFileSync(channelFile, 'utf8'));
    const file = join(out, catalogPath(current.catalog.sha256));
    if (existsSync(file)) {
      const old = readFileSync(file);
      if (canonicalJson(JSON.parse(old.toString('utf8')).assets) === canonicalJson(entries)) catalogBytes = old;
    }
  }
  if (!catalogBytes) {
    catalogBytes = Buffer.from(canonicalJson({
      schema: 'impostor-catalog', schema_version: 1, created_at: rfc3339(seconds),
      baker_version: [...bakers].sort().join(','), assets: entries,
    }), 'utf8');
  }
  const catalogHex = sha256(catalogBytes);
  putBlob(out, catalogPath(catalogHex), catalogBytes);
  const pointer = {
    schema: 'impostor-channel', schema_version: 1, channel, catalog: { sha256: catalogHex, size_bytes: catalogBytes.length },
    published_at: rfc3339(seconds),
  };
  if (signKeyPem) {
    const key = createPrivateKey(signKeyPem);
    const raw = createPublicKey(key).export({ format: 'der', type: 'spki' }).subarray(12);
    pointer.signature = { algorithm: 'ed25519', key_id: sha256(raw).slice(0, 16),
      value: sign(null, catalogBytes, key).toString('base64') };
  }
  // dump(2) + "\n": keys sorted, two-space indent.
  const sorted = JSON.parse(canonicalJson(pointer));
  writeAtomic(channelFile, `${JSON.stringify(sorted, null, 2)}\n`);
  return { catalogSha256: catalogHex, channelFile };
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  const args = process.argv.slice(2);
  let out = null, channel = null, signKey = null, includeQualityViews = false;
  const assets = [];
  for (let i = 0; i < args.length; ++i) {
    if (args[i] === '--out') out = args[++i];
    else if (args[i] === '--channel') channel = args[++i];
    else if (args[i] === '--sign-key') signKey = readFileSync(args[++i], 'utf8');
    else if (args[i] === '--include-quality-views') includeQualityViews = true;
    else if (args[i].includes('=')) {
      const at = args[i].indexOf('=');
      assets.push({ name: args[i].slice(0, at), dir: args[i].slice(at + 1) });
    } else {
      console.error(`unknown argument: ${args[i]}`);
      process.exit(2);
    }
  }
  if (!out || !channel || assets.length === 0) {
    console.error('usage: node publish_release.mjs --out ROOT --channel NAME [--sign-key KEY.pem] NAME=RESULT_DIR...');
    process.exit(2);
  }
  const r = publishRelease({ out, channel, assets, includeQualityViews, signKeyPem: signKey });
  console.log(`${r.channelFile}: catalog ${r.catalogSha256}`);
}
