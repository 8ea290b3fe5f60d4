// manifest.json: the on-disk form of a baked result (v1::Manifest).
// Format: common/manifest_format.md. The worker writes it, stores it as a blob and the
// client installs it next to the maps; ManifestFromJson reads it back.
#ifndef IMPOSTOR_COMMON_MANIFEST_MANIFEST_JSON_H_
#define IMPOSTOR_COMMON_MANIFEST_MANIFEST_JSON_H_

#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

inline constexpr uint32_t kManifestFormatVersion = 2;
// Format 2 (issue 17) renamed the quality block's union colour figures
// (albedo_psnr_union_db_*, albedo_ssim_union_*) and added the shared ones;
// format 1 manifests still read (their union figures under the old names).
inline constexpr uint32_t kOldestManifestFormatVersion = 1;

// Pretty-printed JSON (2-space indent, trailing newline). `manifest_json`
// (the digest of this very text) is left out.
std::string ManifestToJson(const v1::Manifest& manifest);

// INVALID_ARGUMENT naming the first missing or mistyped field.
absl::StatusOr<v1::Manifest> ManifestFromJson(std::string_view json);

std::string_view LayoutJsonName(v1::Layout layout);
// "atlas" (also for PRODUCT_UNSPECIFIED) or "surfels".
std::string_view ProductJsonName(v1::Product product);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_MANIFEST_MANIFEST_JSON_H_
