// A release's catalog and channel pointer (release_format.md): what they
// hold, their canonical JSON, and their validation when read back from a
// mirror (untrusted bytes: every field checked, errors name the field).
// Also the bridge to the result cache: a catalog entry as the v1::Manifest
// listing the cache installs from, and a farm result as a catalog entry.
// Pure functions; thread-safe.
#ifndef IMPOSTOR_CLIENT_DELIVERY_CATALOG_H_
#define IMPOSTOR_CLIENT_DELIVERY_CATALOG_H_

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/strings/string_view.h"
#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"

namespace impostor::delivery {

// One file of an asset, stored at BlobPath(sha256).
struct CatalogFile {
  std::string name;      // plain file name inside the result
  std::string semantic;  // the manifest's, "manifest" for manifest.json
  std::string sha256;    // lowercase hex
  int64_t size_bytes = 0;
  std::string media_type;
  uint32_t width = 0;
  uint32_t height = 0;
  std::string format;
  friend bool operator==(const CatalogFile&, const CatalogFile&) = default;
};

// One named asset: a baked result.
struct CatalogAsset {
  std::string cache_key;
  std::string product;  // "atlas", "surfels", "cards", "lod-chain"
  std::string layout;   // "octahedral", "hemi-octahedral", ...
  uint32_t frames = 0;
  uint32_t resolution = 0;
  std::string baker_version;
  // manifest.json; also the last entry of `files`.
  std::string manifest_sha256;
  int64_t manifest_size_bytes = 0;
  std::vector<CatalogFile> files;
  friend bool operator==(const CatalogAsset&, const CatalogAsset&) = default;
};

struct Catalog {
  int schema_version = 1;
  std::string created_at;  // RFC 3339, UTC
  // The baker versions of the assets, sorted, comma-separated (one for a
  // release baked by one farm version).
  std::string baker_version;
  std::map<std::string, CatalogAsset> assets;  // by asset name
};

struct CatalogSignature {
  std::string algorithm = "ed25519";
  std::string key_id;  // 16 hex: SHA-256 of the raw public key, clipped
  std::string value;   // base64 of the signature over the catalog's bytes
};

struct ChannelPointer {
  int schema_version = 1;
  std::string channel;
  std::string catalog_sha256;
  int64_t catalog_size_bytes = 0;
  std::string published_at;  // RFC 3339, UTC
  std::optional<CatalogSignature> signature;
};

// Canonical JSON: keys sorted, no whitespace; the same catalog gives the
// same bytes, hence the same digest.
std::string CatalogToJson(const Catalog& catalog);
// INVALID_ARGUMENT naming the first bad field (`source` says where the bytes
// came from, for the message); FAILED_PRECONDITION for a schema_version
// newer than this reader's.
absl::StatusOr<Catalog> ParseCatalog(absl::string_view text, absl::string_view source);

std::string ChannelToJson(const ChannelPointer& channel);
absl::StatusOr<ChannelPointer> ParseChannel(absl::string_view text, absl::string_view source);

// A farm result as a catalog entry: every file of `manifest.maps` but the
// quality pass's (IsQualityViewSemantic) unless `include_quality_views`,
// then manifest.json. INVALID_ARGUMENT when the manifest lacks digests or
// names a file with a path.
absl::StatusOr<CatalogAsset> AssetFromManifest(const v1::Manifest& manifest, bool include_quality_views);

// The listing the result cache installs an asset from: `maps` (every file
// but manifest.json, in order) and `manifest_json`, plus cache key, layout,
// frames and resolution.
v1::Manifest ManifestFromAsset(const CatalogAsset& asset);

// RFC 3339 UTC ("2026-12-02T01:02:03Z") of Unix seconds.
std::string Rfc3339Utc(int64_t unix_seconds);

}  // namespace impostor::delivery

#endif  // IMPOSTOR_CLIENT_DELIVERY_CATALOG_H_
