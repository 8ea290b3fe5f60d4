// Names and paths of a release tree (release_format.md): what an asset or
// channel may be called, where a blob, catalog or channel file lives under a
// release root or a mirror base URL, and a file's media type. Pure functions;
// thread-safe.
#ifndef IMPOSTOR_CLIENT_DELIVERY_RELEASE_PATHS_H_
#define IMPOSTOR_CLIENT_DELIVERY_RELEASE_PATHS_H_

#include <string>
#include <string_view>

#include <cstdint>

#include "absl/strings/string_view.h"
#include "absl/status/status.h"

namespace impostor::delivery {

inline constexpr int kCatalogSchemaVersion = 1;
inline constexpr int kChannelSchemaVersion = 1;
inline constexpr size_t kMaxAssetNameLength = 200;
inline constexpr size_t kMaxChannelNameLength = 64;
// A catalog's largest size: a reader holds the whole file while it checks
// its digest, so a channel file naming a larger one (a hostile mirror's)
// is refused before any byte of it is fetched. 10,000 assets of 4 files
// take 11.5 MB.
inline constexpr int64_t kMaxCatalogBytes = int64_t{256} << 20;

// OK, or INVALID_ARGUMENT naming `field`, the name and the rule it breaks:
// 1..200 characters of [A-Za-z0-9._/-], "/"-separated segments, none empty,
// "." or "..", no leading or trailing "/".
absl::Status ValidateAssetName(absl::string_view name, absl::string_view field = "asset name");
// OK, or INVALID_ARGUMENT: [A-Za-z0-9][A-Za-z0-9._-]{0,63}.
absl::Status ValidateChannelName(absl::string_view name, absl::string_view field = "channel");

// Paths relative to a release root (or a mirror base URL), "/"-separated:
// "v1/blobs/sha256/ab/ab12...", "v1/catalogs/sha256/ab/ab12...",
// "v1/channels/NAME.json". `hex` must be a SHA-256 in lowercase hex.
std::string BlobPath(absl::string_view hex);
std::string CatalogPath(absl::string_view hex);
std::string ChannelPath(absl::string_view channel);

// `base` + "/" + `path`, with exactly one "/" between them.
std::string JoinUrl(absl::string_view base, absl::string_view path);

// "image/png", "image/ktx2", "application/json", "model/gltf-binary",
// "image/jpeg", "image/webp", else "application/octet-stream".
std::string MediaTypeForFile(absl::string_view file_name);

// The quality pass's files and the contact sheet (manifest_format.md): for
// people, not drawn by a game, left out of a release unless asked for.
bool IsQualityViewSemantic(absl::string_view semantic);

}  // namespace impostor::delivery

#endif  // IMPOSTOR_CLIENT_DELIVERY_RELEASE_PATHS_H_
