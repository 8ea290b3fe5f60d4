// GET /api/v1/jobs/ID/mesh/FILE over a real HTTP frontend on a real port, in
// front of a scheduler driven by hand: the body is the stored blob (its
// SHA-256) with its type and length; several clients reading a 256 MiB blob
// at once grow the process by far less than one blob (the body streams from
// the store; it used to be read whole for each request); ranges; and bad
// paths, a missing or corrupt blob and the wrong token keep their statuses;
// a result file streams the same way.
// A blob that rots after its last check is cut short, never served whole.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <fstream>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>

#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "server/auth/authenticator.h"
#include "server/http/http_frontend.h"
#include "server/store/token_store.h"
#include "tests/server/scheduler_fixture.h"

namespace impostor {
namespace {

constexpr size_t kPatternBlock = size_t{1} << 20;

// Block `index` of a pattern blob: xorshift64 bytes seeded by the index, so
// a large blob can be made twice (hashed, then written) without being held.
void FillPatternBlock(uint64_t index, size_t bytes, std::string& out) {
  out.resize(bytes);
  uint64_t x = 0x9e3779b97f4a7c15ull ^ (index + 1) * 0xbf58476d1ce4e5b9ull;
  for (size_t i = 0; i < bytes; ++i) {
    if (i % 8 == 0) {
      x ^= x << 13;
      x ^= x >> 7;
      x ^= x << 17;
    }
    out[i] = static_cast<char>(x >> (8 * (i % 8)));
  }
}

// Calls `fn` with each block of the `size`-byte pattern blob.
void ForEachPatternBlock(int64_t size, const std::function<void(std::string_view)>& fn) {
  std::string block;
  for (int64_t at = 0, index = 0; at < size; at += kPatternBlock, ++index) {
    FillPatternBlock(index, static_cast<size_t>(std::min<int64_t>(kPatternBlock, size - at)), block);
    fn(block);
  }
}

std::string PatternBytes(int64_t size) {
  std::string all;
  ForEachPatternBlock(size, [&](std::string_view b) { all.append(b); });
  return all;
}

// A field of /proc/self/status in KiB (VmRSS, VmHWM).
int64_t ProcStatusKiB(const std::string& field) {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind(field + ":", 0) == 0) return std::stoll(line.substr(field.size() + 1));
  }
  ADD_FAILURE() << field << " not in /proc/self/status";
  return 0;
}

// Sets VmHWM to the current VmRSS (Linux 4.0 and later), so the peak seen
// afterwards is this test's alone.
void ResetPeakRss() {
  std::ofstream clear("/proc/self/clear_refs");
  clear << "5";
  clear.close();
  ASSERT_TRUE(clear) << "cannot reset the peak RSS through /proc/self/clear_refs";
}

// All `parties` are inside their download at once: each waits here on its
// first chunk until every other one has had its first chunk too. False
// after `limit` (the server did not serve them side by side).
class AllStarted {
 public:
  explicit AllStarted(int parties) : left_(parties) {}
  bool ArriveAndWait(std::chrono::seconds limit) {
    std::unique_lock lock(mu_);
    if (--left_ == 0) cv_.notify_all();
    return cv_.wait_for(lock, limit, [this] { return left_ <= 0; });
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  int left_;
};

// One GET whose body is hashed as it arrives and not kept.
struct Download {
  httplib::Error error = httplib::Error::Success;  // not Success: no complete response came
  int status = -1;
  httplib::Headers headers;
  int64_t bytes = 0;  // body bytes received, also from a transfer cut short
  std::string sha256;
};

Download StreamingGet(int port, const std::string& path, const httplib::Headers& headers = {},
                      AllStarted* all_started = nullptr) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(60, 0);
  Download d;
  Sha256 hash;
  bool first = true;
  auto res = client.Get(
      path.c_str(), headers,
      [&](const httplib::Response& r) {
        d.status = r.status;
        d.headers = r.headers;
        return true;
      },
      [&](const char* data, size_t n) {
        if (first && all_started != nullptr && !all_started->ArriveAndWait(std::chrono::seconds(120))) return false;
        first = false;
        hash.Update(data, n);
        d.bytes += static_cast<int64_t>(n);
        return true;
      });
  d.error = res.error();
  d.sha256 = hash.FinishHex();
  return d;
}

std::string Header(const httplib::Headers& headers, const std::string& name) {
  auto it = headers.find(name);
  return it == headers.end() ? "" : it->second;
}

class MeshDownloadTest : public testing_support::SchedulerFixture {
 protected:
  void TearDown() override {
    http_.reset();
    authenticator_.reset();
    tokens_.reset();
    SchedulerFixture::TearDown();
  }
  void StartHttp(bool with_tokens = false) {
    if (with_tokens) {
      std::filesystem::create_directories(dir_ / "tokens");
      auto tokens = OpenSqliteTokenStore(dir_ / "tokens");
      ASSERT_TRUE(tokens.ok()) << tokens.status();
      tokens_ = std::move(*tokens);
      authenticator_ = std::make_unique<Authenticator>(tokens_.get());
    }
    auto http = HttpFrontend::Start(
        scheduler_.get(), blobs_.get(),
        {.listen = {"127.0.0.1", 0}, .static_dir = {}, .authenticator = authenticator_.get()});
    ASSERT_TRUE(http.ok()) << http.status();
    http_ = std::move(*http);
  }
  // A token of `role` named `name`; its secret.
  std::string AddToken(const std::string& name, Role role) {
    const std::string secret = NewTokenSecret();
    const int64_t now = std::chrono::duration_cast<std::chrono::milliseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
    const TokenRecord record{.name = name, .role = role, .secret_hash = TokenHash(secret), .created_ms = now};
    EXPECT_TRUE(tokens_->Insert(record).ok());
    return secret;
  }
  // The pattern blob of `size` bytes, written to the store in blocks.
  v1::Digest StorePattern(int64_t size) {
    Sha256 hash;
    ForEachPatternBlock(size, [&](std::string_view b) { hash.Update(b); });
    v1::Digest d;
    d.set_hash(hash.FinishHex());
    d.set_size_bytes(size);
    auto writer = blobs_->NewWriter({d.hash(), size});
    EXPECT_TRUE(writer.ok()) << writer.status();
    if (!writer.ok()) return d;
    ForEachPatternBlock(size, [&](std::string_view b) { EXPECT_TRUE((*writer)->Append(b).ok()); });
    auto committed = (*writer)->Commit();
    EXPECT_TRUE(committed.ok()) << committed.status();
    return d;
  }
  // Submits a mesh of `entry` and `files` (path, digest) as token `owner`;
  // the job id.
  std::string SubmitMesh(const std::pair<std::string, v1::Digest>& entry,
                         const std::vector<std::pair<std::string, v1::Digest>>& files, const std::string& owner = "") {
    v1::SubmitBakeRequest r;
    r.mutable_mesh()->mutable_entry()->set_path(entry.first);
    *r.mutable_mesh()->mutable_entry()->mutable_digest() = entry.second;
    for (const auto& [path, digest] : files) {
      v1::InputFile* f = r.mutable_mesh()->add_files();
      f->set_path(path);
      *f->mutable_digest() = digest;
    }
    auto submitted = scheduler_->Submit(r, "artist", owner);
    EXPECT_TRUE(submitted.ok()) << submitted.status();
    ++now_ms_;
    return submitted.ok() ? submitted->job_id() : "";
  }
  std::string MeshPath(const std::string& job_id, const std::string& file) {
    return "/api/v1/jobs/" + job_id + "/mesh/" + file;
  }
  httplib::Result Get(const std::string& path, const httplib::Headers& headers = {}) {
    httplib::Client client("127.0.0.1", http_->port());
    client.set_read_timeout(60, 0);
    return client.Get(path.c_str(), headers);
  }

  std::unique_ptr<TokenStore> tokens_;
  std::unique_ptr<Authenticator> authenticator_;
  std::unique_ptr<HttpFrontend> http_;
};

TEST_F(MeshDownloadTest, BodyIsTheStoredBlobWithItsTypeAndLength) {
  StartHttp();
  const std::string gltf = R"({"asset":{"version":"2.0"},"buffers":[{"uri":"buffers/mesh.bin"}]})";
  const v1::Digest entry = Store(gltf);
  // Several chunks and a partial one: 64 KiB chunks, 300,007 bytes.
  const v1::Digest bin = StorePattern(300'007);
  const v1::Digest png = Store("\x89PNG\r\n\x1a\n not really");
  const std::string job = SubmitMesh({"scene.gltf", entry}, {{"buffers/mesh.bin", bin}, {"textures/albedo.png", png}});

  struct Case {
    const char* file;
    const v1::Digest* digest;
    const char* content_type;
  };
  for (const Case& c : {Case{"scene.gltf", &entry, "application/json"},
                        Case{"buffers/mesh.bin", &bin, "application/octet-stream"},
                        Case{"textures/albedo.png", &png, "image/png"}}) {
    const Download d = StreamingGet(http_->port(), MeshPath(job, c.file));
    ASSERT_EQ(d.error, httplib::Error::Success) << c.file;
    EXPECT_EQ(d.status, 200) << c.file;
    EXPECT_EQ(d.bytes, c.digest->size_bytes()) << c.file;
    EXPECT_EQ(d.sha256, c.digest->hash()) << c.file;
    EXPECT_EQ(Header(d.headers, "Content-Type"), c.content_type) << c.file;
    EXPECT_EQ(Header(d.headers, "Content-Length"), std::to_string(c.digest->size_bytes())) << c.file;
  }
  // HEAD: the same headers, no body.
  httplib::Client client("127.0.0.1", http_->port());
  auto head = client.Head(MeshPath(job, "buffers/mesh.bin").c_str());
  ASSERT_TRUE(head);
  EXPECT_EQ(head->status, 200);
  EXPECT_EQ(head->get_header_value("Content-Length"), "300007");
  EXPECT_TRUE(head->body.empty());
}

TEST_F(MeshDownloadTest, ConcurrentReadersOfALargeBlobKeepMemoryFarUnderItsSize) {
  constexpr int64_t kBlobBytes = int64_t{256} << 20;
  constexpr int kReaders = 4;
  StartHttp();
  const v1::Digest entry = Store(R"({"asset":{"version":"2.0"}})");
  const v1::Digest big = StorePattern(kBlobBytes);
  const std::string job = SubmitMesh({"scene.gltf", entry}, {{"big.bin", big}});
  // Warm up the server's request path (and verify the blob once, as an
  // earlier reader would have) before the peak is reset.
  ASSERT_EQ(StreamingGet(http_->port(), MeshPath(job, "scene.gltf")).status, 200);
  ASSERT_TRUE(blobs_->Verify({big.hash(), big.size_bytes()}).ok());

  ResetPeakRss();
  const int64_t rss_before_kib = ProcStatusKiB("VmRSS");
  AllStarted all_started(kReaders);
  std::vector<Download> downloads(kReaders);
  std::vector<std::thread> readers;
  for (int i = 0; i < kReaders; ++i) {
    readers.emplace_back(
        [&, i] { downloads[i] = StreamingGet(http_->port(), MeshPath(job, "big.bin"), {}, &all_started); });
  }
  for (std::thread& t : readers) t.join();
  const int64_t growth_bytes = (ProcStatusKiB("VmHWM") - rss_before_kib) * 1024;

  for (int i = 0; i < kReaders; ++i) {
    ASSERT_EQ(downloads[i].error, httplib::Error::Success) << "reader " << i;
    EXPECT_EQ(downloads[i].status, 200) << "reader " << i;
    EXPECT_EQ(downloads[i].bytes, kBlobBytes) << "reader " << i;
    EXPECT_EQ(downloads[i].sha256, big.hash()) << "reader " << i;
  }
  // The server and its readers share this process; the readers keep no
  // body, so the growth is the server's: a few chunks per response, where
  // reading each blob whole took kReaders x 256 MiB.
  RecordProperty("peak_rss_growth_bytes", std::to_string(growth_bytes));
  std::printf("peak RSS growth serving %d readers of a %lld MiB blob: %.1f MiB\n", kReaders,
              static_cast<long long>(kBlobBytes >> 20), growth_bytes / 1048576.0);
  EXPECT_LT(growth_bytes, kBlobBytes / 8) << "peak RSS grew by " << growth_bytes / 1048576.0 << " MiB";
}

TEST_F(MeshDownloadTest, OneRangeIsServedFromTheBlob) {
  StartHttp();
  constexpr int64_t kSize = 200'000;  // spans chunks: 64 KiB each
  const v1::Digest bin = StorePattern(kSize);
  const std::string bytes = PatternBytes(kSize);
  const std::string job = SubmitMesh({"mesh.glb", bin}, {});

  struct Case {
    const char* range;
    int status;
    const char* content_range;  // "" = none
    int64_t offset, length;     // of the body, when 200 or 206
  };
  const Case cases[] = {
      {"bytes=0-99", 206, "bytes 0-99/200000", 0, 100},
      {"bytes=65000-140000", 206, "bytes 65000-140000/200000", 65000, 75001},
      {"bytes=150000-", 206, "bytes 150000-199999/200000", 150000, 50000},
      {"bytes=-10", 206, "bytes 199990-199999/200000", 199990, 10},
      {"bytes=-300000", 206, "bytes 0-199999/200000", 0, kSize},
      // A last byte past the end is clamped to it (RFC 9110 14.1.2).
      {"bytes=199990-250000", 206, "bytes 199990-199999/200000", 199990, 10},
      {"bytes=200000-", 416, "bytes */200000", 0, 0},
      {"bytes=-0", 416, "bytes */200000", 0, 0},
      // Several ranges: the whole blob, as the RFC allows.
      {"bytes=0-9,20-29", 200, "", 0, kSize},
  };
  for (const Case& c : cases) {
    auto res = Get(MeshPath(job, "mesh.glb"), {{"Range", c.range}});
    ASSERT_TRUE(res) << c.range << ": " << httplib::to_string(res.error());
    EXPECT_EQ(res->status, c.status) << c.range;
    EXPECT_EQ(res->get_header_value("Content-Range"), c.content_range) << c.range;
    if (c.status == 416) continue;
    EXPECT_EQ(res->get_header_value("Content-Type"), "model/gltf-binary") << c.range;
    EXPECT_EQ(res->get_header_value("Content-Length"), std::to_string(c.length)) << c.range;
    EXPECT_TRUE(res->body == bytes.substr(static_cast<size_t>(c.offset), static_cast<size_t>(c.length)))
        << c.range << ": " << res->body.size() << " bytes";
  }
}

TEST_F(MeshDownloadTest, BadRequestsKeepTheirStatuses) {
  StartHttp();
  const v1::Digest entry = Store(R"({"asset":{"version":"2.0"}})");
  const v1::Digest gone = Store("a buffer that will be evicted");
  const v1::Digest rotten = Store("a buffer whose bytes will change");
  const std::string job = SubmitMesh({"scene.gltf", entry}, {{"gone.bin", gone}, {"rotten.bin", rotten}});
  ASSERT_TRUE(blobs_->Remove(gone.hash()).ok());
  {
    // Other bytes of the same length: its file changed, so the next read
    // re-hashes it before it answers.
    const std::filesystem::path path = blobs_->PathFor({rotten.hash(), rotten.size_bytes()});
    std::filesystem::permissions(path, std::filesystem::perms::owner_write, std::filesystem::perm_options::add);
    std::ofstream(path, std::ios::binary | std::ios::trunc) << "A BUFFER WHOSE BYTES WILL CHANGE";
  }

  struct Case {
    std::string path;
    int status;
    const char* expect;  // in the error message
  };
  const Case cases[] = {
      {MeshPath("job-unknown", "scene.gltf"), 404, "job_id: no job"},
      {MeshPath(job, "other.gltf"), 404, "has no mesh file \\\"other.gltf\\\""},
      {MeshPath(job, "../../../etc/passwd"), 404, "has no mesh file"},
      {MeshPath(job, "%2e%2e%2f%2e%2e%2fetc%2fpasswd"), 404, "has no mesh file"},
      {MeshPath(job, "gone.bin"), 404, "not found"},
      {MeshPath(job, "rotten.bin"), 500, "no longer match the digest"},
  };
  for (const Case& c : cases) {
    auto res = Get(c.path);
    ASSERT_TRUE(res) << c.path << ": " << httplib::to_string(res.error());
    EXPECT_EQ(res->status, c.status) << c.path;
    EXPECT_EQ(res->get_header_value("Content-Type"), "application/json") << c.path;
    EXPECT_NE(res->body.find(c.expect), std::string::npos) << c.path << ": " << res->body;
  }
}

TEST_F(MeshDownloadTest, ABlobThatRotsAfterItsLastCheckIsCutShortNotServedWhole) {
  StartHttp();
  constexpr int64_t kSize = 300'000;
  const v1::Digest bin = StorePattern(kSize);
  const std::string job = SubmitMesh({"mesh.glb", bin}, {});
  const BlobDigest digest{bin.hash(), bin.size_bytes()};
  ASSERT_TRUE(blobs_->Verify(digest).ok());  // remembered as good until its file changes
  {
    // Bit rot: one byte flips and the file keeps its modification time, so
    // the store still trusts its last check and the status line says 200.
    const std::filesystem::path path = blobs_->PathFor(digest);
    struct stat st {};
    ASSERT_EQ(::stat(path.c_str(), &st), 0);
    std::filesystem::permissions(path, std::filesystem::perms::owner_write, std::filesystem::perm_options::add);
    const int fd = ::open(path.c_str(), O_WRONLY);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::pwrite(fd, "\xff", 1, 1000), 1);
    const timespec times[2] = {st.st_atim, st.st_mtim};
    ASSERT_EQ(::futimens(fd, times), 0);
    ::close(fd);
  }

  const Download d = StreamingGet(http_->port(), MeshPath(job, "mesh.glb"));
  // Either refused before the status line or cut short; never all the bytes
  // with a success.
  if (d.error == httplib::Error::Success) {
    EXPECT_GE(d.status, 500) << "served " << d.bytes << " bytes of a corrupt blob";
  } else {
    EXPECT_LT(d.bytes, kSize) << "every byte of a corrupt blob went out";
  }
  EXPECT_NE(d.sha256, bin.hash());
  // The blob is quarantined: the next request is a plain 404.
  EXPECT_FALSE(blobs_->Contains(digest));
  auto again = Get(MeshPath(job, "mesh.glb"));
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 404) << again->body;
}

// The result files endpoint streams the same way and keeps its cache
// header on the bytes only: an error may change (a re-bake restores a blob).
TEST_F(MeshDownloadTest, AResultFileStreamsWithItsCacheHeader) {
  StartHttp();
  Submit(Request("mesh"), "artist");
  const v1::LeasedJob job = Lease();
  const v1::CompleteJobRequest done = Result(job);
  ASSERT_TRUE(scheduler_->Complete(done).ok());
  const std::string files = "/api/v1/results/" + job.cache_key() + "/files/";

  const Download map = StreamingGet(http_->port(), files + "albedo_alpha.png");
  ASSERT_EQ(map.error, httplib::Error::Success);
  EXPECT_EQ(map.status, 200);
  EXPECT_EQ(map.sha256, done.result().maps(0).digest().hash());
  EXPECT_EQ(Header(map.headers, "Content-Type"), "image/png");
  EXPECT_EQ(Header(map.headers, "Cache-Control"), "max-age=86400, immutable");

  auto missing = Get(files + "nothing.png");
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 404);
  EXPECT_FALSE(missing->has_header("Cache-Control"));
}

TEST_F(MeshDownloadTest, OnlyTheSubmitterOrAnAdminReadsTheMesh) {
  StartHttp(/*with_tokens=*/true);
  const std::string owner = AddToken("mesh-owner", Role::kSubmitter);
  const std::string other = AddToken("someone-else", Role::kSubmitter);
  const std::string reader = AddToken("mesh-reader", Role::kReader);
  const std::string worker = AddToken("a-worker", Role::kWorker);
  const std::string admin = AddToken("mesh-admin", Role::kAdmin);
  const v1::Digest bin = StorePattern(100'000);
  const std::string job = SubmitMesh({"mesh.glb", bin}, {}, "mesh-owner");

  struct Case {
    const char* who;
    const std::string* token;  // nullptr = none
    std::string path;
    int status;
  };
  const Case cases[] = {
      {"no token", nullptr, MeshPath(job, "mesh.glb"), 401},
      {"another submitter", &other, MeshPath(job, "mesh.glb"), 403},
      {"a reader", &reader, MeshPath(job, "mesh.glb"), 403},
      {"a worker", &worker, MeshPath(job, "mesh.glb"), 403},
      {"the submitter", &owner, MeshPath(job, "mesh.glb"), 200},
      {"an admin", &admin, MeshPath(job, "mesh.glb"), 200},
      {"the submitter, unknown job", &owner, MeshPath("job-unknown", "mesh.glb"), 404},
  };
  for (const Case& c : cases) {
    httplib::Headers headers;
    if (c.token != nullptr) headers.emplace("Authorization", "Bearer " + *c.token);
    const Download d = StreamingGet(http_->port(), c.path, headers);
    ASSERT_EQ(d.error, httplib::Error::Success) << c.who;
    EXPECT_EQ(d.status, c.status) << c.who;
    if (c.status == 200) {
      EXPECT_EQ(d.sha256, bin.hash()) << c.who;
    } else {
      EXPECT_EQ(Header(d.headers, "Content-Type"), "application/json") << c.who;
      EXPECT_LT(d.bytes, 1000) << c.who << ": the refusal carries mesh bytes";
    }
  }
}

}  // namespace
}  // namespace impostor
