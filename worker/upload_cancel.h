// Cancels, from another thread, the gRPC calls of an upload under way
// (EarlyResultUpload::Finish stops its uploads when the bake ends). Each
// call of the upload registers its context while it runs (UploadCancel::
// Call); Cancel() cancels those under way, and a call registered after it
// is cancelled as it starts (gRPC honours a TryCancel that comes before the
// call), so its status is CANCELLED.
//
// Thread-safety: all methods from any thread.
#ifndef IMPOSTOR_WORKER_UPLOAD_CANCEL_H_
#define IMPOSTOR_WORKER_UPLOAD_CANCEL_H_

#include <algorithm>
#include <mutex>
#include <vector>

#include <grpcpp/client_context.h>

namespace impostor {

class UploadCancel {
 public:
  // Registers `ctx` for the call's lifetime; `cancel` may be null (nothing
  // can cancel the call).
  class Call {
   public:
    Call(UploadCancel* cancel, grpc::ClientContext* ctx) : cancel_(cancel), ctx_(ctx) {
      if (cancel_ != nullptr) cancel_->Add(ctx_);
    }
    ~Call() {
      if (cancel_ != nullptr) cancel_->Remove(ctx_);
    }
    Call(const Call&) = delete;
    Call& operator=(const Call&) = delete;

   private:
    UploadCancel* const cancel_;
    grpc::ClientContext* const ctx_;
  };

  void Cancel() {
    std::lock_guard lock(mu_);
    cancelled_ = true;
    for (grpc::ClientContext* ctx : active_) ctx->TryCancel();
  }

 private:
  void Add(grpc::ClientContext* ctx) {
    std::lock_guard lock(mu_);
    if (cancelled_) ctx->TryCancel();
    active_.push_back(ctx);
  }
  void Remove(grpc::ClientContext* ctx) {
    std::lock_guard lock(mu_);
    active_.erase(std::find(active_.begin(), active_.end(), ctx));
  }

  std::mutex mu_;
  bool cancelled_ = false;
  std::vector<grpc::ClientContext*> active_;
};

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_UPLOAD_CANCEL_H_
