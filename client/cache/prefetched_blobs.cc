#include "client/cache/prefetched_blobs.h"

#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/base/sdk_log.h"
#include "client/transfer/blob_batch.h"
#include "client/transfer/blob_download.h"

namespace impostor::sdk {

BlobReader PrefetchingFarmReader(Transport& transport, const v1::Manifest& listing,
                                 const std::function<bool(const v1::Digest&)>& wanted, const CancelSource* cancel,
                                 BlobReader stream) {
  if (!stream) stream = FarmBlobReader(transport);
  std::vector<v1::Digest> small;
  std::set<std::string> seen;
  int64_t bytes = 0;
  auto consider = [&](const v1::Digest& digest) {
    if (!FitsBlobBatch(digest) || bytes + digest.size_bytes() > kMaxPrefetchBytes) return;
    if (!seen.insert(digest.hash()).second || !wanted(digest)) return;
    small.push_back(digest);
    bytes += digest.size_bytes();
  };
  for (const v1::MapFile& map : listing.maps()) consider(map.digest());
  consider(listing.manifest_json());

  auto held = std::make_shared<std::map<std::string, std::string>>();  // hash -> verified bytes
  for (const std::vector<size_t>& batch : PackBlobBatches(small)) {
    std::vector<v1::Digest> digests;
    for (size_t i : batch) digests.push_back(small[i]);
    const absl::Status read = ReadBlobBatch(
        transport, digests,
        [&](size_t i, std::string_view data) {
          (*held)[digests[i].hash()] = std::string(data);
          return absl::OkStatus();
        },
        nullptr, cancel);
    if (!read.ok()) {
      // Whatever is left streams one blob at a time, as before batches.
      SdkLog().debug("cache: BatchReadBlobs gave {} of {} blobs ({}); streaming the rest", held->size(), small.size(),
                     read.ToString());
      break;
    }
  }
  return [stream = std::move(stream), held](const v1::Digest& digest, int64_t offset, Sha256& hash,
                                            const std::function<absl::Status(std::string_view)>& sink,
                                            const CancelSource* c) -> absl::Status {
    auto it = held->find(digest.hash());
    if (it == held->end() || static_cast<int64_t>(it->second.size()) != digest.size_bytes() || offset < 0 ||
        offset > digest.size_bytes()) {
      return stream(digest, offset, hash, sink, c);
    }
    const std::string_view rest = std::string_view(it->second).substr(static_cast<size_t>(offset));
    hash.Update(rest);
    if (absl::Status s = sink(rest); !s.ok()) return s;
    // The bytes were verified whole; the partial file's first `offset`
    // bytes, which `hash` saw, may not have been.
    if (const std::string actual = hash.FinishHex(); actual != digest.hash()) {
      return absl::DataLossError(absl::StrCat("blob ", digest.hash(), "/", digest.size_bytes(), ": bytes hash to ",
                                              actual));
    }
    return absl::OkStatus();
  };
}

}  // namespace impostor::sdk
