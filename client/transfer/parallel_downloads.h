// Runs a result's blob downloads side by side: a few ReadBlob streams in
// flight at once over the one channel (HTTP/2 multiplexes them), so that a
// result of many small files waits for one round trip per batch of streams
// rather than one per file, and the client's hashing and writing overlap
// the server's reading. One stream runs them in order on the caller's
// thread.
#ifndef IMPOSTOR_CLIENT_TRANSFER_PARALLEL_DOWNLOADS_H_
#define IMPOSTOR_CLIENT_TRANSFER_PARALLEL_DOWNLOADS_H_

#include <cstddef>
#include <functional>

#include "absl/status/status.h"
#include "client/transport/retry.h"

namespace impostor::sdk {

// Streams in flight at once for one result on this machine: 1 on two
// hardware threads or fewer, 4 above. On the 2-core machine the streams'
// threads cost more than the round trips they save: `impostor fetch` of the
// quickstart's 39-file, 26 MB result took 0.25 s wall and 0.17-0.19 s CPU
// with one stream, against 0.28 s and 0.23 s with 2, 0.35 s and 0.27 s with
// 4, 0.32 s and 0.27 s with 8 (medians of 9 in one run; 5x the context
// switches and 1,800 more page faults with 4), as with a 3-file result
// before. With cores to spare the extra CPU is free and the server's
// reading overlaps the client's hashing and writing; that side is not
// measured here yet.
int DefaultParallelDownloads();

// Runs `download(i, cancel)` for every i in [0, count), starting them in
// index order, at most `parallel` at a time (>= 1; the caller's thread is
// one of them). Returns once every started call has returned: OK when all
// were OK, otherwise the first failure. After a failure no further call
// starts and `cancel` (the one handed to the running calls) is cancelled,
// so they end promptly; their CANCELLED never hides the failure that caused
// it. `outer` (may be null) cancels them all too. `download` is called
// from several threads at once.
absl::Status RunParallelDownloads(size_t count, int parallel, const CancelSource* outer,
                                  const std::function<absl::Status(size_t i, const CancelSource& cancel)>& download);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_PARALLEL_DOWNLOADS_H_
