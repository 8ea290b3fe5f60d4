// impostor-three/release: reading a published release without three.js
// (channel, catalog, verified files, Cache Storage); runs in browsers,
// workers and Node.js.
export {
  ReleaseClient, ImpostorFetchError, ImpostorIntegrityError, DEFAULT_CACHE_NAME, CACHE_KEY_ORIGIN, sha256Hex, toHex,
  ed25519RawKey,
} from './release_client.js';
export { parseCatalog, parseChannel, ImpostorSchemaError } from './catalog.js';
export {
  blobPath, catalogPath, channelPath, joinUrl, mediaTypeForFile, validateAssetName, validateChannelName, isSha256Hex,
  CATALOG_SCHEMA_VERSION, CHANNEL_SCHEMA_VERSION,
} from './release_paths.js';
