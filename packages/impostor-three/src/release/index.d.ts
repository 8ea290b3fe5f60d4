// Type declarations of impostor-three/release (written by hand; the
// JavaScript in this folder is the implementation).

/** The Cache Storage cache verified files are kept in. */
export const DEFAULT_CACHE_NAME: 'impostor-blobs-v1';
/** Origin of Cache Storage keys: CACHE_KEY_ORIGIN + "v1/blobs/sha256/<hh>/<hex>". */
export const CACHE_KEY_ORIGIN: string;
export const CATALOG_SCHEMA_VERSION: 1;
export const CHANNEL_SCHEMA_VERSION: 1;

/** Bytes whose SHA-256 is not the one their name promised. */
export class ImpostorIntegrityError extends Error {
  readonly name: 'ImpostorIntegrityError';
  /** The file, as "<asset>/<file name>" or "catalog of channel ...". */
  readonly file: string;
  readonly url: string;
  /** The digest the catalog (or channel file) names. */
  readonly expected: string;
  /** The digest of the bytes received. */
  readonly actual: string;
}

/** No source gave verified bytes; `attempts` holds each source's failure, in order. */
export class ImpostorFetchError extends Error {
  readonly name: 'ImpostorFetchError';
  readonly file: string;
  readonly sha256: string;
  readonly attempts: ReadonlyArray<{ url: string; error: Error }>;
}

/** A schema_version newer than this reader knows (update the package). */
export class ImpostorSchemaError extends Error {
  readonly name: 'ImpostorSchemaError';
}

export interface ChannelPointer {
  schemaVersion: number;
  channel: string;
  catalog: { sha256: string; sizeBytes: number };
  publishedAt: string;
  signature: { algorithm: string; keyId: string; value: string } | null;
}

export interface CatalogFile {
  name: string;
  semantic: string;
  sha256: string;
  sizeBytes: number;
  mediaType: string;
  width: number;
  height: number;
  format: string;
}

export interface CatalogAsset {
  name: string;
  cacheKey: string;
  /** "atlas", "surfels", "cards" or "lod-chain". */
  product: string;
  /** "octahedral", "hemi-octahedral", "azimuth-elevation", "ring-top" or "billboard". */
  layout: string;
  frames: number;
  resolution: number;
  bakerVersion: string;
  manifest: { sha256: string; sizeBytes: number };
  /** The maps in the manifest's order, then manifest.json. */
  files: CatalogFile[];
}

export interface Catalog {
  schemaVersion: number;
  createdAt: string;
  bakerVersion: string;
  assets: Map<string, CatalogAsset>;
}

/** Parses and checks a channel file; throws a TypeError naming the source and field. */
export function parseChannel(text: string, source: string): ChannelPointer;
/** Parses and checks a catalog; throws a TypeError naming the source and field. */
export function parseCatalog(text: string, source: string): Catalog;

export function isSha256Hex(value: unknown): boolean;
/** Throws a TypeError naming the rule an asset name breaks. */
export function validateAssetName(name: string, field?: string): void;
/** Throws a TypeError unless the name matches [A-Za-z0-9][A-Za-z0-9._-]{0,63}. */
export function validateChannelName(name: string, field?: string): void;
/** "v1/blobs/sha256/<hh>/<hex>" */
export function blobPath(hex: string): string;
/** "v1/catalogs/sha256/<hh>/<hex>" */
export function catalogPath(hex: string): string;
/** "v1/channels/<channel>.json" */
export function channelPath(channel: string): string;
export function joinUrl(base: string, path: string): string;
export function mediaTypeForFile(name: string): string;

export function toHex(bytes: ArrayBuffer | Uint8Array): string;
export function sha256Hex(subtle: SubtleCrypto, bytes: BufferSource): Promise<string>;
/** The raw 32-byte Ed25519 key from raw bytes, their base64, or a PEM public key. */
export function ed25519RawKey(key: Uint8Array | ArrayBuffer | string): Uint8Array;

/** The subset of the CacheStorage interface the client uses. */
export interface CacheStorageLike {
  open(name: string): Promise<{
    match(key: string): Promise<Response | undefined>;
    put(key: string, response: Response): Promise<void>;
    delete(key: string): Promise<boolean>;
  }>;
}

export interface ReleaseClientOptions {
  /** Base URLs of release trees (each the directory holding v1/), tried in order. */
  mirrors?: string[];
  channel?: string | null;
  fetch?: typeof fetch;
  subtle?: SubtleCrypto;
  /** Default: the global `caches`; null keeps nothing. */
  cacheStorage?: CacheStorageLike | null;
  /** Default 'impostor-blobs-v1'. */
  cacheName?: string;
  /** Refuse catalogs not signed by this Ed25519 key (raw 32 bytes, base64 or PEM). */
  publicKey?: Uint8Array | ArrayBuffer | string | null;
  /** A download that receives nothing for this long moves on to the next mirror. Default 15000. */
  stallTimeoutMs?: number;
  /** Merged into every fetch (headers, credentials). */
  requestInit?: RequestInit;
  resolveUrl?: (url: string) => string;
}

export interface ResolvedRelease {
  channel: ChannelPointer;
  /** 'cache' when every mirror failed and the last channel file seen was used. */
  channelSource: 'network' | 'cache';
  channelUrl: string;
  catalog: Catalog;
  catalogSha256: string;
  catalogBytes: Uint8Array;
  catalogSource: 'network' | 'cache';
}

export interface VerifiedFile extends CatalogFile {
  bytes: Uint8Array;
  source: 'network' | 'cache';
  url: string;
  verified: true;
}

export interface LoadedAsset {
  name: string;
  cacheKey: string;
  entry: CatalogAsset;
  /** manifest.json, parsed. */
  manifest: any;
  /** manifest.json first, then the selected files. */
  files: VerifiedFile[];
  channel: ChannelPointer;
  catalogSha256: string;
}

export interface ProgressLike {
  loaded: number;
  total: number;
  lengthComputable: boolean;
}

/**
 * Reads a published release from mirrors: channel file (cache: 'no-cache'),
 * catalog and files, each verified by SHA-256 before it is returned and kept
 * in Cache Storage. Safe for concurrent calls; one download per digest.
 */
export class ReleaseClient {
  constructor(options?: ReleaseClientOptions);
  mirrors: string[];
  channel: string | null;
  setMirrors(mirrors: string[]): void;
  setChannel(channel: string): void;
  /** Forgets the resolved channel; the next call reads the channel file again. */
  refresh(): void;
  resolveChannel(): Promise<ResolvedRelease>;
  fetchVerified(file: {
    file: string; sha256: string; sizeBytes: number; path?: string; onBytes?: (n: number) => void;
  }): Promise<{ bytes: Uint8Array; source: 'network' | 'cache'; url: string }>;
  /** Every file of the asset whose semantic is in `semantics` (all when null), manifest.json always. */
  loadAsset(name: string, options?: {
    semantics?: string[] | null; onProgress?: (event: ProgressLike) => void;
  }): Promise<LoadedAsset>;
}
