// The real AssetService over a fresh BlobStore, served on a free loopback
// port behind a decorator the test supplies (it counts calls, plays an
// older server, holds or refuses streams), with a stub to reach it: what
// the worker's upload tests run against.
#ifndef IMPOSTOR_TESTS_WORKER_IN_PROCESS_ASSETS_H_
#define IMPOSTOR_TESTS_WORKER_IN_PROCESS_ASSETS_H_

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "server/blobs/blob_store.h"
#include "server/rpc/services.h"

namespace impostor::testing {

class InProcessAssets {
 public:
  using Decorate = std::function<std::unique_ptr<v1::AssetService::Service>(v1::AssetService::Service* real)>;

  // Opens a store under `dir`/store and serves `decorate(real service)`.
  // Call under ASSERT_NO_FATAL_FAILURE.
  void Start(const std::filesystem::path& dir, const Decorate& decorate) {
    auto store = BlobStore::Open(dir / "store");
    ASSERT_TRUE(store.ok()) << store.status();
    store_ = std::move(*store);
    real_ = std::make_unique<AssetServiceImpl>(store_.get(), /*scheduler=*/nullptr);
    front_ = decorate(real_.get());
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.SetMaxReceiveMessageSize(16 << 20);  // as server/main.cc: a full batch and its digests
    builder.RegisterService(front_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    stub_ = std::make_unique<v1::AssetService::Stub>(
        grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials()));
  }

  ~InProcessAssets() {
    if (server_ != nullptr) server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  }

  BlobStore& store() { return *store_; }
  v1::AssetService::Stub& stub() { return *stub_; }

 private:
  std::unique_ptr<BlobStore> store_;
  std::unique_ptr<AssetServiceImpl> real_;
  std::unique_ptr<v1::AssetService::Service> front_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<v1::AssetService::Stub> stub_;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_WORKER_IN_PROCESS_ASSETS_H_
