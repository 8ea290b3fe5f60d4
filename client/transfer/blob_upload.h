// Uploads one local file as a blob through AssetService.UploadBlob, however
// slow the link, and gives up only on a link that stalls. Runs on the
// caller's thread.
//
// Resumable: the server keeps what a broken stream brought (for a while,
// within its bounds), and the next stream starts after it (QueryUpload says
// where), so a cut upload sends only the bytes the server lacks.
#ifndef IMPOSTOR_CLIENT_TRANSFER_BLOB_UPLOAD_H_
#define IMPOSTOR_CLIENT_TRANSFER_BLOB_UPLOAD_H_

#include <cstddef>
#include <filesystem>

#include "absl/status/status.h"
#include "client/transport/retry.h"
#include "client/transport/transport.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

// Bytes per UploadBlob message. The stall watchdog sees progress only when
// the link has taken a whole message (gRPC has no per-byte progress), so a
// message must cross the slowest link well within rpc_timeout_seconds: a
// 1 MiB one needs 87 s at 12 KB/s, a 64 KiB one 5 s (the server's ReadBlob
// messages are 64 KiB for the same reason). Loopback throughput is the same
// either way (128 MiB blobs: 450-500 MB/s with 64 KiB and with 1 MiB).
inline constexpr size_t kUploadChunkBytes = size_t{64} << 10;

// Sends the file at `path`, whose bytes hash to `digest`, to the server's
// blob store. OK when the server stored it or had it already.
//
// No deadline on the whole upload: a stream that keeps moving goes on
// however slow the link. A stream is cut only when the link takes no
// message for rpc_timeout_seconds, or when, after the last message, the
// server's answer does not come within rpc_timeout_seconds per message the
// link may still hold (DEADLINE_EXCEEDED, "the link stalled", naming the
// seconds and the bytes sent; Transport::UploadBlob). A cut or broken
// stream (UNAVAILABLE, DEADLINE_EXCEEDED) is tried again as RetryPolicy
// decides: up to max_attempts tries in a row, and through a server outage
// for up to max_outage_seconds. Each try asks the server how many bytes it
// kept (AssetService.QueryUpload) and sends only the rest; a try after
// which the server kept more starts that count over, as a download's
// progress does. A blob larger than one message asks before its first try
// too, so an upload given up earlier (a CLI interrupted) resumes as well.
// A server without QueryUpload, or one that kept nothing, gets the whole
// blob again.
//
// Errors: the server's refusal as it said it (RESOURCE_EXHAUSTED,
// INVALID_ARGUMENT, ...; see AssetService.UploadBlob); INTERNAL naming the
// file when it cannot be opened or read.
//
// `cancel` (may be null; must outlive the call): CancelSource::Cancel()
// from any thread ends the upload promptly wherever it is (a stream in
// flight, a backoff wait through an outage) with cancel->error()
// (CANCELLED).
absl::Status UploadBlobFile(Transport& transport, const std::filesystem::path& path, const v1::Digest& digest,
                            const CancelSource* cancel = nullptr);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_BLOB_UPLOAD_H_
