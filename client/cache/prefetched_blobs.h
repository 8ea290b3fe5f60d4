// The farm's BlobReader for one install, with the result's small blobs read
// many to a call before the install starts (AssetService.BatchReadBlobs:
// client/transfer/blob_batch.h): a result's 36 view images and its manifest
// cost one round trip instead of one ReadBlob stream each (issue 45). The
// install itself is unchanged: each blob still goes through its partial
// file, its lock and its links (FetchBlob), only its bytes come from memory.
#ifndef IMPOSTOR_CLIENT_CACHE_PREFETCHED_BLOBS_H_
#define IMPOSTOR_CLIENT_CACHE_PREFETCHED_BLOBS_H_

#include <cstdint>
#include <functional>

#include "client/cache/partial_download.h"
#include "client/transport/retry.h"
#include "client/transport/transport.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

// At most this many bytes of a result are held in memory at once.
inline constexpr int64_t kMaxPrefetchBytes = int64_t{16} << 20;

// Reads the small blobs of `listing` for which `wanted` is true (e.g. no
// partial file of theirs exists yet) in batches, verified, and returns a
// reader that serves those from memory and every other blob (or all, when
// the server predates BatchReadBlobs or a batch failed) with `stream`, by
// default ResumeBlobDownload (FarmBlobReader). A blob a batch could not
// give is left to that stream, whose error then names it as before.
// `transport` must outlive the reader.
BlobReader PrefetchingFarmReader(Transport& transport, const v1::Manifest& listing,
                                 const std::function<bool(const v1::Digest&)>& wanted, const CancelSource* cancel,
                                 BlobReader stream = nullptr);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_PREFETCHED_BLOBS_H_
