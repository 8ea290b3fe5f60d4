// FetchResultFiles with several ReadBlob streams in flight
// (client/transfer/parallel_downloads.h) against the fake of fake_server.h:
// the streams really overlap and stay bounded, and every guarantee of a
// one-at-a-time fetch holds among them: a forged blob fails the fetch
// naming its file with nothing renamed in, a broken stream resumes at its
// offset, a server gone mid-way leaves the folder as it was. Small files
// come many to a BatchReadBlobs call (client/transfer/blob_batch.h) from a
// server that has it, checked as streamed ones are, and one stream each
// from a server that does not.
#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "client/transfer/blob_batch.h"
#include "client/transfer/result_fetch.h"
#include "common/net/batch_read.h"
#include "client/transport/transport.h"
#include "tests/client/fake_server.h"

namespace impostor::sdk {
namespace {

constexpr int kStreams = 4;

class ParallelFetchTest : public FakeServerTest {
 protected:
  // AddResult's two maps and twelve more of 2-3 KB (the fake sends 1000
  // bytes a message, so each takes a few).
  std::string AddManyMapResult() {
    const std::string key = AddResult();
    std::lock_guard lock(fake_.mu);
    v1::Manifest& m = fake_.results[key];
    for (int i = 0; i < 12; ++i) {
      const std::string name = "view_" + std::to_string(i) + ".png";
      const std::string bytes(2000 + 100 * i, static_cast<char>('a' + i));
      auto* map = m.add_maps();
      map->set_semantic("view");
      map->set_file(name);
      *map->mutable_digest() = DigestOf(bytes);
      fake_.blobs[Sha256Hex(bytes)] = bytes;
      contents_[name] = bytes;
    }
    return key;
  }

  std::unique_ptr<Transport> ConnectTransport(int max_attempts = 3) {
    ClientOptions options;
    options.server = "127.0.0.1:" + std::to_string(port_);
    options.connect_timeout_seconds = 5;
    options.max_attempts = max_attempts;
    options.max_outage_seconds = 0;
    auto transport = Transport::Connect(options);
    EXPECT_TRUE(transport.ok()) << transport.status();
    return transport.ok() ? std::move(*transport) : nullptr;
  }

  void ExpectFolderEmpty(const std::string& after) {
    if (!fs::exists(dir_)) return;
    for (const auto& entry : fs::directory_iterator(dir_)) ADD_FAILURE() << after << ": left " << entry.path();
  }
};

// The fake holds every ReadBlob before its first byte until kStreams
// streams are open at once: a fetch of one file at a time never gets there
// and fails ABORTED after 20 s.
TEST_F(ParallelFetchTest, StreamsOverlapStayBoundedAndTheFilesArriveWhole) {
  const std::string key = AddManyMapResult();
  {
    std::lock_guard lock(fake_.mu);
    fake_.reads_must_overlap = kStreams;
  }
  std::unique_ptr<Transport> transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<FetchResult> r = FetchResultFiles(*transport, key, dir_, kStreams);
  ASSERT_TRUE(r.ok()) << r.status();
  for (const auto& [name, bytes] : contents_) EXPECT_EQ(ReadAll(dir_ / name), bytes) << name;
  EXPECT_EQ(r->files.back(), dir_ / "manifest.json") << "files keep the manifest's order";
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.max_open_reads, kStreams) << "never more streams than asked for";
}

// A forged blob among streams in flight: DATA_LOSS naming its file, the
// other streams cancelled, nothing of the result renamed in, no temporary
// file left.
TEST_F(ParallelFetchTest, AForgedBlobAmongManyFailsNamingItAndRenamesNothingIn) {
  const std::string key = AddManyMapResult();
  {
    std::lock_guard lock(fake_.mu);
    fake_.reads_must_overlap = kStreams;
    fake_.corrupt.insert(Sha256Hex(contents_["view_9.png"]));
  }
  std::unique_ptr<Transport> transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<FetchResult> r = FetchResultFiles(*transport, key, dir_, kStreams);
  ASSERT_EQ(r.status().code(), absl::StatusCode::kDataLoss) << r.status();
  EXPECT_NE(r.status().message().find("view_9.png"), std::string::npos) << r.status();
  ExpectFolderEmpty("after a forged blob");
}

// A stream broken midway among others resumes at its offset; the others
// are not restarted.
TEST_F(ParallelFetchTest, ABrokenStreamAmongManyResumesAtItsOffset) {
  const std::string key = AddManyMapResult();
  const std::string broken = Sha256Hex(contents_["view_11.png"]);
  {
    std::lock_guard lock(fake_.mu);
    fake_.break_once.insert(broken);
  }
  std::unique_ptr<Transport> transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<FetchResult> r = FetchResultFiles(*transport, key, dir_, kStreams);
  ASSERT_TRUE(r.ok()) << r.status();
  for (const auto& [name, bytes] : contents_) EXPECT_EQ(ReadAll(dir_ / name), bytes) << name;
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.read_offsets_by_hash[broken], (std::vector<int64_t>{0, 2000}));
  EXPECT_EQ(fake_.read_offsets.size(), contents_.size() + 1) << "one stream per file, and one resume";
}

// The server answers no more ReadBlobs (down) partway: the fetch fails
// with the RPC's error and the folder is as it was.
TEST_F(ParallelFetchTest, AServerGoneMidwayLeavesTheFolderAsItWas) {
  const std::string key = AddManyMapResult();
  {
    std::lock_guard lock(fake_.mu);
    fake_.break_once.insert(Sha256Hex(contents_["view_4.png"]));
    fake_.refuse_after_break = 1000;  // every ReadBlob after the break: UNAVAILABLE
  }
  std::unique_ptr<Transport> transport = ConnectTransport(/*max_attempts=*/2);
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<FetchResult> r = FetchResultFiles(*transport, key, dir_, kStreams);
  ASSERT_EQ(r.status().code(), absl::StatusCode::kUnavailable) << r.status();
  ExpectFolderEmpty("after the server went away");
}

// A server with BatchReadBlobs: every small file (the 14 of the result and
// its manifest) in one call, no ReadBlob stream; a file over 1 MiB streams.
TEST_F(ParallelFetchTest, SmallFilesComeManyToACallAndLargeOnesStream) {
  const std::string key = AddManyMapResult();
  const std::string large(kBatchReadBlobMaxBytes + 1, 'L');
  {
    std::lock_guard lock(fake_.mu);
    fake_.batch_reads = true;
    auto* map = fake_.results[key].add_maps();
    map->set_semantic("large");
    map->set_file("large.bin");
    *map->mutable_digest() = DigestOf(large);
    fake_.blobs[Sha256Hex(large)] = large;
    contents_["large.bin"] = large;
  }
  std::unique_ptr<Transport> transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<FetchResult> r = FetchResultFiles(*transport, key, dir_, kStreams);
  ASSERT_TRUE(r.ok()) << r.status();
  for (const auto& [name, bytes] : contents_) EXPECT_EQ(ReadAll(dir_ / name), bytes) << name;
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.batch_read_calls, 1);
  EXPECT_EQ(fake_.batch_read_blobs, static_cast<int>(contents_.size()) - 1);
  EXPECT_EQ(fake_.read_offsets_by_hash.size(), 1u) << "only the large file streams";
  EXPECT_TRUE(fake_.read_offsets_by_hash.contains(Sha256Hex(large)));
}

// A forged blob in a batch: DATA_LOSS naming its file and the hash the
// bytes had, nothing of the result renamed in, no temporary file left.
TEST_F(ParallelFetchTest, AForgedBlobInABatchFailsNamingItsFileAndRenamesNothingIn) {
  const std::string key = AddManyMapResult();
  {
    std::lock_guard lock(fake_.mu);
    fake_.batch_reads = true;
    fake_.corrupt.insert(Sha256Hex(contents_["view_7.png"]));
  }
  std::unique_ptr<Transport> transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<FetchResult> r = FetchResultFiles(*transport, key, dir_, kStreams);
  ASSERT_EQ(r.status().code(), absl::StatusCode::kDataLoss) << r.status();
  EXPECT_NE(r.status().message().find("view_7.png"), std::string::npos) << r.status();
  EXPECT_NE(r.status().message().find("hash to"), std::string::npos) << r.status();
  ExpectFolderEmpty("after a forged blob in a batch");
}

// A blob the server no longer has: its own NOT_FOUND, naming the file.
TEST_F(ParallelFetchTest, ABlobMissingFromABatchFailsNamingItsFile) {
  const std::string key = AddManyMapResult();
  {
    std::lock_guard lock(fake_.mu);
    fake_.batch_reads = true;
    fake_.blobs.erase(Sha256Hex(contents_["view_3.png"]));
  }
  std::unique_ptr<Transport> transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<FetchResult> r = FetchResultFiles(*transport, key, dir_, kStreams);
  ASSERT_EQ(r.status().code(), absl::StatusCode::kNotFound) << r.status();
  EXPECT_NE(r.status().message().find("view_3.png"), std::string::npos) << r.status();
  ExpectFolderEmpty("after a missing blob in a batch");
}

// A server from before BatchReadBlobs (UNIMPLEMENTED): every file streams,
// side by side, and arrives whole.
TEST_F(ParallelFetchTest, AServerWithoutBatchReadsIsReadOneStreamPerFile) {
  const std::string key = AddManyMapResult();
  {
    std::lock_guard lock(fake_.mu);
    fake_.reads_must_overlap = kStreams;
  }
  std::unique_ptr<Transport> transport = ConnectTransport();
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<FetchResult> r = FetchResultFiles(*transport, key, dir_, kStreams);
  ASSERT_TRUE(r.ok()) << r.status();
  for (const auto& [name, bytes] : contents_) EXPECT_EQ(ReadAll(dir_ / name), bytes) << name;
  std::lock_guard lock(fake_.mu);
  EXPECT_EQ(fake_.read_offsets.size(), contents_.size());
  EXPECT_EQ(fake_.max_open_reads, kStreams);
}

TEST(PackBlobBatches, KeepsOrderAndBothLimits) {
  auto digest = [](int64_t size) {
    v1::Digest d;
    d.set_hash(std::string(64, 'a'));
    d.set_size_bytes(size);
    return d;
  };
  // By bytes: 3 + 1 MiB fill 4 MiB exactly; the next starts a batch.
  std::vector<v1::Digest> by_bytes = {digest(3 << 20), digest(1 << 20), digest(1), digest(0)};
  EXPECT_EQ(PackBlobBatches(by_bytes), (std::vector<std::vector<size_t>>{{0, 1}, {2, 3}}));
  // By count: 1,000 a batch.
  std::vector<v1::Digest> by_count(kMaxBatchReadDigests * 2 + 1, digest(10));
  const std::vector<std::vector<size_t>> batches = PackBlobBatches(by_count);
  ASSERT_EQ(batches.size(), 3u);
  EXPECT_EQ(batches[0].size(), static_cast<size_t>(kMaxBatchReadDigests));
  EXPECT_EQ(batches[1].front(), static_cast<size_t>(kMaxBatchReadDigests));
  EXPECT_EQ(batches[2], (std::vector<size_t>{static_cast<size_t>(kMaxBatchReadDigests) * 2}));
  EXPECT_TRUE(PackBlobBatches({}).empty());
  EXPECT_TRUE(FitsBlobBatch(digest(kBatchReadBlobMaxBytes)));
  EXPECT_FALSE(FitsBlobBatch(digest(kBatchReadBlobMaxBytes + 1)));
}

}  // namespace
}  // namespace impostor::sdk
