#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/net/farm_http_base.h"
#include "common/util/sha256.h"
#include "server/rpc/batch_read_request.h"
#include "server/rpc/batch_update_request.h"
#include "server/rpc/grpc_status.h"
#include "server/rpc/read_message_size.h"
#include "server/rpc/services.h"

namespace impostor {
namespace {

constexpr int kMaxFindMissing = 10'000;
// Blobs of one BatchUpdateBlobs stored side by side (see there).
constexpr int kBatchStoreThreads = 8;
// ReadBlob reads blobs in pieces of 64 KiB, its smallest message. A client
// keeps whole messages only: a stream cut midway loses the message under
// way, and a message is all a slow link's stall watchdog can see arrive
// (gRPC has no per-byte progress). At 1 MiB a 12 KB/s link took 87 s per
// message and lost it at every cut; at 64 KiB it takes 5 s. A stream's
// messages grow to 256 KiB once it has shown a fast reader
// (read_message_size.h).
constexpr size_t kReadChunkBytes = ReadMessageSize::kSmallBytes;

BlobDigest ToDigest(const v1::Digest& d) { return {d.hash(), d.size_bytes()}; }

// One blob of a batch, verified as an UploadBlob of it is (size, then
// SHA-256) and stored as one is (BlobStore::Put: synced, then published);
// true when it was present already. Refusals name both digests (the
// store's own hash mismatch names both hashes). A blob the store has is
// verified in memory and not written again: a result's repeated images or
// a retried batch cost no temporary file and no sync each.
absl::StatusOr<bool> PutBatchBlob(BlobStore& blobs, const v1::Digest& digest, const std::string& data) {
  if (static_cast<int64_t>(data.size()) != digest.size_bytes()) {
    return absl::InvalidArgumentError(absl::StrCat("size mismatch: digest says ", digest.hash(), "/",
                                                   digest.size_bytes(), ", the data is ", Sha256Hex(data), "/",
                                                   data.size()));
  }
  if (!blobs.Contains(ToDigest(digest))) return blobs.Put(ToDigest(digest), data);
  if (const std::string actual = Sha256Hex(data); actual != digest.hash()) {
    return absl::InvalidArgumentError(
        absl::StrCat("blob hash mismatch: digest says ", digest.hash(), ", content hashes to ", actual));
  }
  return true;
}

}  // namespace

grpc::Status AssetServiceImpl::FindMissingBlobs(grpc::ServerContext*, const v1::FindMissingBlobsRequest* request,
                                                v1::FindMissingBlobsResponse* response) {
  if (request->digests_size() > kMaxFindMissing) {
    return ToGrpc(absl::InvalidArgumentError(
        absl::StrCat("digests: ", request->digests_size(), " digests is over the limit of ", kMaxFindMissing)));
  }
  for (int i = 0; i < request->digests_size(); ++i) {
    const v1::Digest& d = request->digests(i);
    if (auto s = ValidateDigest(absl::StrCat("digests[", i, "]"), d.hash(), d.size_bytes()); !s.ok()) return ToGrpc(s);
    if (!blobs_->Contains(ToDigest(d))) *response->add_missing() = d;
  }
  return grpc::Status::OK;
}

// Refusals go out with their error reason: STORE_FULL when the store has no
// space, which a worker waits out (common/error_reason.h). A stream that
// ends before the blob's last byte (the client's link broke, or it gave
// up) leaves its bytes in the store as a kept partial for QueryUpload and a
// resume; a refused one (bad bytes, a full disk) leaves nothing.
grpc::Status AssetServiceImpl::UploadBlob(grpc::ServerContext* context,
                                          grpc::ServerReader<v1::UploadBlobRequest>* reader,
                                          v1::UploadBlobResponse* response) {
  v1::UploadBlobRequest chunk;
  if (!reader->Read(&chunk)) return ToGrpc(absl::InvalidArgumentError("digest: the stream carried no message"));
  if (!chunk.has_digest()) return ToGrpc(absl::InvalidArgumentError("digest: required in the first message"));
  const BlobDigest digest = ToDigest(chunk.digest());
  auto writer = blobs_->NewWriter(digest, chunk.offset(), [context] { context->TryCancel(); });
  if (!writer.ok()) return ToGrpc(writer.status(), context);
  BlobStore::Writer& out = **writer;
  do {
    if (out.preempted()) {
      const int64_t kept = out.written();
      out.Keep();
      return ToGrpc(absl::UnavailableError(absl::StrCat("blob ", digest.hash, ": another UploadBlob stream resumed this "
                                                        "upload after its ", kept,
                                                        " bytes; QueryUpload and resume")),
                    context);
    }
    if (auto s = out.Append(chunk.data()); !s.ok()) return ToGrpc(s, context);
  } while (reader->Read(&chunk));
  if (out.written() < digest.size_bytes) {
    const int64_t received = out.written();
    out.Keep();
    return ToGrpc(absl::InvalidArgumentError(absl::StrCat("blob ", digest.hash, ": the stream ended after ", received,
                                                          " of its ", digest.size_bytes,
                                                          " bytes; QueryUpload says how many were kept to resume from")),
                  context);
  }
  auto present = out.Commit();
  if (!present.ok()) return ToGrpc(present.status(), context);
  response->mutable_digest()->set_hash(digest.hash);
  response->mutable_digest()->set_size_bytes(digest.size_bytes);
  response->set_already_present(*present);
  return grpc::Status::OK;
}

// Each blob's refusal goes in its slot with its error reason (STORE_FULL),
// as UploadBlob's would go in trailing metadata; the call itself is OK.
// The blobs are stored kBatchStoreThreads at a time: each is synced (file
// and folder) before it is published, and syncs one after another wait for
// a journal commit each, where side by side they share commits.
grpc::Status AssetServiceImpl::BatchUpdateBlobs(grpc::ServerContext* context,
                                                const v1::BatchUpdateBlobsRequest* request,
                                                v1::BatchUpdateBlobsResponse* response) {
  if (absl::Status s = ValidateBatchUpdateRequest(*request); !s.ok()) return ToGrpc(s);
  for (const v1::BatchUpdateBlobsRequest::Request& blob : request->requests()) {
    *response->add_responses()->mutable_digest() = blob.digest();
  }
  std::atomic<int> next{0};
  std::atomic<bool> cancelled{false};
  auto store = [&] {
    for (int i; !cancelled && (i = next.fetch_add(1)) < request->requests_size();) {
      if (context->IsCancelled()) {
        cancelled = true;
        return;
      }
      const v1::BatchUpdateBlobsRequest::Request& blob = request->requests(i);
      v1::BatchUpdateBlobsResponse::Response* out = response->mutable_responses(i);
      const absl::StatusOr<bool> present = PutBatchBlob(*blobs_, blob.digest(), blob.data());
      if (present.ok()) {
        out->set_already_present(*present);
      } else {
        out->set_code(static_cast<int32_t>(present.status().code()));
        out->set_message(absl::StrCat("requests[", i, "]: ", present.status().message()));
        out->set_reason(ErrorReasonOf(present.status()));
      }
    }
  };
  std::vector<std::thread> threads;
  for (int t = 1; t < std::min(kBatchStoreThreads, request->requests_size()); ++t) threads.emplace_back(store);
  store();
  for (std::thread& t : threads) t.join();
  if (cancelled) return grpc::Status(grpc::StatusCode::CANCELLED, "the client cancelled the call");
  return grpc::Status::OK;
}

grpc::Status AssetServiceImpl::QueryUpload(grpc::ServerContext*, const v1::QueryUploadRequest* request,
                                           v1::QueryUploadResponse* response) {
  if (!request->has_digest()) return ToGrpc(absl::InvalidArgumentError("digest: required"));
  const BlobDigest digest = ToDigest(request->digest());
  auto kept = blobs_->PartialBytes(digest);  // validates the digest
  if (!kept.ok()) return ToGrpc(kept.status());
  if (blobs_->Contains(digest)) {
    response->set_complete(true);
    return grpc::Status::OK;
  }
  response->set_committed_bytes(*kept);
  return grpc::Status::OK;
}

grpc::Status AssetServiceImpl::ReadBlob(grpc::ServerContext* context, const v1::ReadBlobRequest* request,
                                        grpc::ServerWriter<v1::ReadBlobResponse>* writer) {
  // The blob is read in kReadChunkBytes pieces; a message gathers as many
  // as ReadMessageSize allows (64 KiB, 256 KiB on a fast stream).
  v1::ReadBlobResponse out;
  ReadMessageSize size;
  const auto start = std::chrono::steady_clock::now();
  auto send = [&] {
    const auto before = std::chrono::steady_clock::now();
    const bool written = writer->Write(out);
    const auto after = std::chrono::steady_clock::now();
    size.Sent(out.data().size(), std::chrono::duration<double>(after - before).count(),
              std::chrono::duration<double>(after - start).count());
    out.clear_data();
    return written;
  };
  const absl::Status s = blobs_->Read(ToDigest(request->digest()), request->offset(), request->limit(),
                                      kReadChunkBytes, [&](std::string_view data, int64_t offset) {
                                        if (context->IsCancelled()) return false;
                                        if (out.data().empty()) out.set_offset(offset);
                                        out.mutable_data()->append(data.data(), data.size());
                                        return out.data().size() < size.limit() || send();
                                      });
  // What is gathered goes only after the whole blob verified (Read's last
  // chunk is passed on before its hash is checked: the client checks too).
  if (s.ok() && !out.data().empty() && !send()) return grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
  return ToGrpc(s);
}

grpc::Status AssetServiceImpl::BatchReadBlobs(grpc::ServerContext* context, const v1::BatchReadBlobsRequest* request,
                                              v1::BatchReadBlobsResponse* response) {
  if (absl::Status s = ValidateBatchReadRequest(*request); !s.ok()) return ToGrpc(s);
  for (const v1::Digest& digest : request->digests()) {
    if (context->IsCancelled()) return grpc::Status(grpc::StatusCode::CANCELLED, "the client cancelled the call");
    v1::BatchReadBlobsResponse::Blob* blob = response->add_blobs();
    *blob->mutable_digest() = digest;
    // ReadAll hashes the whole blob on the way, as a whole ReadBlob does.
    absl::StatusOr<std::string> data = blobs_->ReadAll(ToDigest(digest));
    if (data.ok()) {
      blob->set_data(std::move(*data));
    } else {
      blob->set_code(static_cast<int32_t>(data.status().code()));
      blob->set_message(std::string(data.status().message()));
    }
  }
  return grpc::Status::OK;
}

grpc::Status AssetServiceImpl::GetResult(grpc::ServerContext* context, const v1::GetResultRequest* request,
                                         v1::Manifest* response) {
  auto m = scheduler_->GetResult(request->cache_key());
  if (!m.ok()) return ToGrpc(m.status());
  *response = std::move(*m);
  // Where the result's files can be read over HTTP (--http-advertise): the
  // client takes the large ones from there.
  if (!advertised_http_.empty() && context != nullptr) {
    context->AddInitialMetadata(kFarmHttpMetadataKey, advertised_http_);
  }
  return grpc::Status::OK;
}

}  // namespace impostor

namespace impostor {

grpc::Status AssetServiceImpl::PinResult(grpc::ServerContext*, const v1::PinResultRequest* request,
                                         v1::PinResultResponse*) {
  return ToGrpc(scheduler_->PinResult(request->cache_key(), request->pinned()));
}

}  // namespace impostor
