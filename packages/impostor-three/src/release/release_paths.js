// Names and paths of a release tree (client/delivery/release_format.md):
// what an asset or channel may be called, where a blob, catalog or channel
// file lives under a mirror base URL, and a file's media type. The same
// rules as the C++ SDK's client/delivery/release_paths.h. Pure functions.

export const CATALOG_SCHEMA_VERSION = 1;
export const CHANNEL_SCHEMA_VERSION = 1;
export const MAX_ASSET_NAME_LENGTH = 200;

const SHA256_HEX = /^[0-9a-f]{64}$/;
const CHANNEL_NAME = /^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$/;
const ASSET_NAME_CHARS = /^[A-Za-z0-9._/-]+$/;

export function isSha256Hex(value) {
  return typeof value === 'string' && SHA256_HEX.test(value);
}

// Throws a TypeError naming `field`, the name and the rule it breaks.
export function validateAssetName(name, field = 'asset name') {
  const shown = JSON.stringify(String(name).slice(0, 80));
  if (typeof name !== 'string' || name.length < 1 || name.length > MAX_ASSET_NAME_LENGTH) {
    throw new TypeError(`${field} ${shown}: must be 1..${MAX_ASSET_NAME_LENGTH} characters`);
  }
  if (!ASSET_NAME_CHARS.test(name)) throw new TypeError(`${field} ${shown}: may hold only [A-Za-z0-9._/-]`);
  for (const segment of name.split('/')) {
    if (segment === '' || segment === '.' || segment === '..') {
      throw new TypeError(`${field} ${shown}: "/"-separated segments, none empty, "." or ".." (no leading or trailing "/")`);
    }
  }
}

export function validateChannelName(name, field = 'channel') {
  if (typeof name !== 'string' || !CHANNEL_NAME.test(name)) {
    throw new TypeError(`${field} ${JSON.stringify(String(name).slice(0, 80))}: must match [A-Za-z0-9][A-Za-z0-9._-]{0,63}`);
  }
}

export const blobPath = (hex) => `v1/blobs/sha256/${hex.slice(0, 2)}/${hex}`;
export const catalogPath = (hex) => `v1/catalogs/sha256/${hex.slice(0, 2)}/${hex}`;
export const channelPath = (channel) => `v1/channels/${channel}.json`;

// `base` + "/" + `path` with exactly one "/" between them.
export function joinUrl(base, path) {
  return `${String(base).replace(/\/+$/, '')}/${String(path).replace(/^\/+/, '')}`;
}

const MEDIA_TYPES = {
  png: 'image/png', ktx2: 'image/ktx2', json: 'application/json', glb: 'model/gltf-binary', jpg: 'image/jpeg',
  jpeg: 'image/jpeg', webp: 'image/webp',
};

export function mediaTypeForFile(name) {
  const dot = name.lastIndexOf('.');
  return (dot >= 0 && MEDIA_TYPES[name.slice(dot + 1).toLowerCase()]) || 'application/octet-stream';
}
