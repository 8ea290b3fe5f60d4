#include "worker/early_result_upload.h"

#include <spdlog/spdlog.h>

#include "common/util/log_escape.h"

namespace impostor {

EarlyResultUpload::EarlyResultUpload(
    std::function<absl::Status(const std::function<absl::Status(v1::AssetService::Stub&)>&)> call,
    const std::atomic<bool>& cancelled)
    : call_(std::move(call)), cancelled_(cancelled), thread_([this] { Run(); }) {}

EarlyResultUpload::~EarlyResultUpload() { Finish(); }

void EarlyResultUpload::Offer(const std::filesystem::path& file, const BlobDigest& digest) {
  ResultFile f{file, {}};
  f.digest.set_hash(digest.hash);
  f.digest.set_size_bytes(digest.size_bytes);
  {
    std::lock_guard lock(mu_);
    if (finishing_) return;
    queue_.push_back(std::move(f));
  }
  offered_.notify_one();
}

int EarlyResultUpload::Finish() {
  {
    std::lock_guard lock(mu_);
    finishing_ = true;
    // What has not started is left to the upload after the bake, which
    // would otherwise wait for it here.
    queue_.clear();
  }
  cancel_.Cancel();
  offered_.notify_one();
  if (thread_.joinable()) thread_.join();
  return stored_;
}

void EarlyResultUpload::Run() {
  ResultUploadLink link;
  link.call = call_;
  // One try only: the upload after the bake rides out outages and full
  // stores for every file this leaves.
  link.upload_patiently = [](const ResultFile&) {
    return absl::UnavailableError("left for the upload after the bake");
  };
  while (true) {
    std::vector<ResultFile> files;
    {
      std::unique_lock lock(mu_);
      offered_.wait(lock, [&] { return finishing_ || !queue_.empty(); });
      if (queue_.empty()) return;
      files.assign(queue_.begin(), queue_.end());
      queue_.clear();
    }
    // One file at a time: the bake's quality pass has the cores meanwhile.
    for (const ResultFile& file : files) {
      if (cancelled_) break;
      {
        std::lock_guard lock(mu_);
        if (finishing_) return;
      }
      const absl::Status s = UploadResultFiles({file}, link, /*parallel=*/1, {.cancel = &cancel_});
      if (s.ok()) {
        ++stored_;
        continue;
      }
      spdlog::debug("event=early_upload_left file=\"{}\" error=\"{}\"", EscapeUntrusted(file.path.filename().string()),
                    EscapeUntrusted(std::string(s.message())));
    }
  }
}

}  // namespace impostor
