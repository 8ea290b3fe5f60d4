// The worker's upload of one result file as a blob (AssetService.UploadBlob)
// over a synchronous stub: resumable, with a stall watchdog and no deadline
// on the whole stream. Used by WorkerLoop (worker_calls.cc), which rides out
// outages and full stores around it; no retrying here.
//
// Thread-safety: a free function; concurrent calls share nothing.
#ifndef IMPOSTOR_WORKER_RESULT_UPLOAD_H_
#define IMPOSTOR_WORKER_RESULT_UPLOAD_H_

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "absl/status/status.h"
#include "impostor/v1/asset_service.grpc.pb.h"
#include "worker/upload_cancel.h"

namespace impostor {

struct ResultUploadOptions {
  // The stream is cancelled when the link takes no message for this long,
  // and when, after the last message, the server's answer does not come
  // within it once per message the link may still hold, plus once more
  // (DEADLINE_EXCEEDED saying that the link stalled). > 0. A write the
  // link never took returns only once the connection is given up (gRPC
  // completes no step of a cancelled call before that): the channel's
  // keepalive bounds it (the worker's --keepalive-seconds sets
  // TCP_USER_TIMEOUT), so a dead link ends the call within about the
  // stall limit or the keepalive timeout, whichever is longer.
  std::chrono::milliseconds stall_limit{std::chrono::seconds(30)};
  // Bytes per UploadBlob message: a message must cross the slowest link
  // well within stall_limit (64 KiB take 5 s at 12 KB/s).
  size_t chunk_bytes = size_t{64} << 10;
  // Deadline of the QueryUpload asked before the stream.
  std::chrono::milliseconds query_timeout{std::chrono::seconds(30)};
  // Lets another thread cancel the calls (upload_cancel.h); null: none can.
  UploadCancel* cancel = nullptr;
};

// Uploads the file at `path`, whose bytes hash to `digest`. A blob larger
// than one message first asks the server how much of it it kept from an
// earlier, broken try (QueryUpload) and sends only the rest; a server
// without QueryUpload (UNIMPLEMENTED) or that kept nothing gets it whole.
// OK when the server stored the blob or had it already; otherwise the
// server's refusal as the gRPC status (its error reason, e.g. STORE_FULL,
// kept on the status: common/error_reason.h), DEADLINE_EXCEEDED for a
// stalled link, INTERNAL naming the file when it cannot be read. A caller
// that tries again resumes where this try was cut.
//
// `bytes_sent` (may be null) is increased by the blob bytes this call put
// on the link.
absl::Status UploadResultFile(v1::AssetService::Stub& assets, const std::filesystem::path& path,
                              const v1::Digest& digest, const ResultUploadOptions& options = {},
                              int64_t* bytes_sent = nullptr);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_RESULT_UPLOAD_H_
