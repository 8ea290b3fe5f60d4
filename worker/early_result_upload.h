// A result's maps uploaded while the bake goes on. The atlas bake hands
// each map over as soon as its bytes are final (AtlasBakeRequest::
// map_written); the quality pass runs for seconds after that, and this
// uploads the maps meanwhile on a thread of its own, so the upload after
// the bake has only the pass's small files left to send.
//
// Best effort: a file it could not upload (the server away, the store full,
// the job cancelled, the bake over first) is left to the result's upload
// after the bake (WorkerLoop::UploadAll), which asks the server before each
// stream (QueryUpload says a blob is complete, or how much of it a cut
// stream left) and sends what is missing. So an early upload can neither
// fail a job nor hold it up: it tries each file once, and Finish cancels
// the call under way.
//
// Thread-safety: Offer from any thread (the encoders call it several at
// once); Finish from the owner.
#ifndef IMPOSTOR_WORKER_EARLY_RESULT_UPLOAD_H_
#define IMPOSTOR_WORKER_EARLY_RESULT_UPLOAD_H_

#include <atomic>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <mutex>
#include <thread>

#include "common/util/sha256.h"
#include "worker/result_files_upload.h"
#include "worker/upload_cancel.h"

namespace impostor {

class EarlyResultUpload {
 public:
  // `call` reaches the farm, one attempt a call (ResultUploadLink::call).
  // Nothing is uploaded once `cancelled` is true.
  EarlyResultUpload(std::function<absl::Status(const std::function<absl::Status(v1::AssetService::Stub&)>&)> call,
                    const std::atomic<bool>& cancelled);
  EarlyResultUpload(const EarlyResultUpload&) = delete;
  EarlyResultUpload& operator=(const EarlyResultUpload&) = delete;
  ~EarlyResultUpload();  // Finish()

  // Queues `file` (bytes final, hashing to `digest`) for upload.
  void Offer(const std::filesystem::path& file, const BlobDigest& digest);

  // Stops: cancels the call under way (the server keeps what it received
  // for a resume), drops the files not started, and returns how many of
  // the offered files were stored. Later calls return the same.
  int Finish();

 private:
  void Run();

  const std::function<absl::Status(const std::function<absl::Status(v1::AssetService::Stub&)>&)> call_;
  const std::atomic<bool>& cancelled_;
  std::mutex mu_;
  std::condition_variable offered_;
  UploadCancel cancel_;
  std::deque<ResultFile> queue_;  // guarded by mu_
  bool finishing_ = false;        // guarded by mu_
  int stored_ = 0;                // written by the thread; read after it is joined
  std::thread thread_;            // last: starts once the rest is set
};

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_EARLY_RESULT_UPLOAD_H_
