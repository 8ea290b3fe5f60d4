// The server's signature on a result's manifest.json (issue 14): which
// worker token baked it. Workers write manifest.json and cannot be trusted
// to name themselves, so the server adds "baked_by" to the text the worker
// uploaded and stores the stamped text as a new blob; the result then lists
// that blob, and `impostor fetch`, the cache and the SDK install it as is.
#ifndef IMPOSTOR_SERVER_SCHEDULER_MANIFEST_STAMP_H_
#define IMPOSTOR_SERVER_SCHEDULER_MANIFEST_STAMP_H_

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"
#include "server/blobs/blob_store.h"

namespace impostor {

// Largest manifest.json the server stamps (a LOD chain's views fit easily).
inline constexpr int64_t kMaxStampedManifestBytes = 16 << 20;
// Deeper JSON is refused (ours is about 5 levels deep).
inline constexpr int kMaxManifestDepth = 32;
// Larger manifests are stored without indentation; smaller ones too when
// indenting would make them more than kMaxIndentGrowth times (plus the
// allowance) their compact size.
inline constexpr int64_t kMaxIndentedManifestBytes = 256 << 10;
inline constexpr size_t kMaxIndentGrowth = 2;
inline constexpr size_t kIndentAllowanceBytes = 64 << 10;

// The digest of the worker's manifest.json (`manifest_json`) with
// "baked_by": `baked_by` set, stored in `blobs`. Other members are kept as
// the worker wrote them (the same 2-space layout ManifestToJson uses).
// FAILED_PRECONDITION when the blob is not in the store; INVALID_ARGUMENT
// naming result.manifest_json when it is larger than
// kMaxStampedManifestBytes or not a JSON object; INTERNAL on disk errors.
absl::StatusOr<v1::Digest> StampBakedBy(BlobStore& blobs, const v1::Digest& manifest_json, const std::string& baked_by);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_SCHEDULER_MANIFEST_STAMP_H_
