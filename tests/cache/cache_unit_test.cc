// Pure pieces of the cache: LRU accounting, the `.entry` record format and
// its bad inputs, reading small files, the single-flight coordinator, and a
// partial file's download and cleanup through the descriptor it keeps.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <latch>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "client/base/small_file.h"
#include "client/cache/cache_layout.h"
#include "client/cache/cached_result_rep.h"
#include "client/cache/download_coordinator.h"
#include "client/cache/lru_index.h"
#include "client/cache/manifest_summary.h"
#include "client/cache/partial_download.h"
#include "client/cache/work_queue.h"
#include "common/util/sha256.h"

namespace impostor::sdk {
namespace {

TEST(LruIndex, VictimsAreLeastRecentlyUsedFirstAndSkipPinned) {
  LruIndex lru;
  lru.Insert("a", 10, 1);
  lru.Insert("b", 10, 2);
  lru.Insert("c", 10, 3);
  lru.Touch("a", 4);  // order now c, b... newest first: a, c, b
  EXPECT_EQ(lru.total_bytes(), 30);
  EXPECT_EQ(lru.Victims(20, nullptr), (std::vector<std::string>{"b"}));
  EXPECT_EQ(lru.Victims(5, nullptr), (std::vector<std::string>{"b", "c", "a"}));
  EXPECT_EQ(lru.Victims(5, [](const std::string& k) { return k == "c"; }), (std::vector<std::string>{"b", "a"}));
  EXPECT_TRUE(lru.Victims(30, nullptr).empty());
  lru.Erase("b");
  EXPECT_EQ(lru.total_bytes(), 20);
  lru.Insert("a", 15, 5);  // re-insert replaces the size
  EXPECT_EQ(lru.total_bytes(), 25);
  ASSERT_EQ(lru.Items().size(), 2u);
  EXPECT_EQ(lru.Items()[0].key, "a");
}

EntryRecord SampleRecord() {
  EntryRecord r;
  r.key = std::string(64, 'a');
  r.layout = "octahedral";
  r.frames = 12;
  r.resolution = 2048;
  r.files.push_back({"albedo_alpha", "albedo_alpha.png", std::string(64, 'b'), 100, 2048, 2048, "png_rgba8", 7, 9});
  r.files.push_back({"manifest", "manifest.json", std::string(64, 'c'), 10, 0, 0, "json", 8, 10});
  return r;
}

TEST(EntryRecord, RoundTripsThroughJson) {
  const EntryRecord r = SampleRecord();
  auto back = EntryRecordFromJson(EntryRecordToJson(r));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->key, r.key);
  ASSERT_EQ(back->files.size(), 2u);
  EXPECT_EQ(back->files[0].inode, 7u);
  EXPECT_EQ(back->files[1].mtime_ns, 10);
  EXPECT_EQ(back->TotalBytes(), 110);
}

TEST(EntryRecord, BadRecordsAreRefusedByName) {
  struct Case {
    const char* name;
    std::function<void(EntryRecord&)> change;
    std::string raw;  // used instead when set
  };
  const Case cases[] = {
      {"not json", nullptr, "{nope"},
      {"not an object", nullptr, "[1,2]"},
      {"missing files", nullptr, R"({"format":1,"key":")" + std::string(64, 'a') + R"(","layout":"x","frames":1,"resolution":1})"},
      {"key not hex", [](EntryRecord& r) { r.key = "zz"; }, ""},
      {"file name with a directory", [](EntryRecord& r) { r.files[0].name = "../evil.png"; }, ""},
      {"file named .entry", [](EntryRecord& r) { r.files[0].name = ".entry"; }, ""},
      {"bad digest", [](EntryRecord& r) { r.files[0].sha256 = "xyz"; }, ""},
      {"negative size", [](EntryRecord& r) { r.files[0].size_bytes = -1; }, ""},
      {"no files", [](EntryRecord& r) { r.files.clear(); }, ""},
  };
  for (const Case& c : cases) {
    std::string json = c.raw;
    if (json.empty()) {
      EntryRecord r = SampleRecord();
      c.change(r);
      json = EntryRecordToJson(r);
    }
    EXPECT_EQ(EntryRecordFromJson(json).status().code(), absl::StatusCode::kInvalidArgument) << c.name;
  }
}

// A fresh folder under the test's temporary directory, removed with
// everything in it when the test ends.
class ScratchDir {
 public:
  ScratchDir() {
    std::string pattern = (std::filesystem::path(::testing::TempDir()) / "small-file-XXXXXX").string();
    if (::mkdtemp(pattern.data()) != nullptr) path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path Write(const std::string& name, const std::string& bytes) const {
    const std::filesystem::path p = path_ / name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }

 private:
  std::filesystem::path path_;
};

TEST(SmallFile, ReadsWholeFilesUpToTheLimit) {
  ScratchDir dir;
  ASSERT_FALSE(dir.path().empty());
  std::string bytes(100000, '\0');
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<char>(i * 31 + 7);
  EXPECT_EQ(ReadSmallFile(dir.Write("big", bytes), 100000).value(), bytes);  // exactly the limit
  EXPECT_EQ(ReadSmallFile(dir.Write("empty", ""), 0).value(), "");
  EXPECT_EQ(ReadSmallFile(dir.Write("text", "hello"), 1 << 20).value(), "hello");
}

TEST(SmallFile, RefusesWhatIsMissingTooLargeOrNotAFile) {
  ScratchDir dir;
  ASSERT_FALSE(dir.path().empty());
  const std::filesystem::path file = dir.Write("file", std::string(100, 'x'));
  EXPECT_EQ(ReadSmallFile(dir.path() / "absent", 10).status().code(), absl::StatusCode::kNotFound);
  // A file where a folder should be (ENOTDIR) is absent as well.
  EXPECT_EQ(ReadSmallFile(file / "below", 10).status().code(), absl::StatusCode::kNotFound);
  const absl::Status too_large = ReadSmallFile(file, 99).status();
  EXPECT_EQ(too_large.code(), absl::StatusCode::kOutOfRange);
  EXPECT_NE(too_large.message().find("100 bytes is over the limit of 99 bytes"), std::string::npos) << too_large;
  EXPECT_NE(too_large.message().find(file.string()), std::string::npos) << too_large;
  const absl::Status folder = ReadSmallFile(dir.path(), 1 << 20).status();
  EXPECT_EQ(folder.code(), absl::StatusCode::kInternal) << folder;
  EXPECT_NE(folder.message().find(dir.path().string()), std::string::npos) << folder;
}

TEST(EntryRecord, AnAbsentRecordIsNotFoundAndAnOversizedOneIsRefused) {
  ScratchDir dir;
  ASSERT_FALSE(dir.path().empty());
  EXPECT_EQ(ReadEntryRecord(dir.path()).status().code(), absl::StatusCode::kNotFound);
  dir.Write(kEntryRecordName, EntryRecordToJson(SampleRecord()));
  EXPECT_EQ(ReadEntryRecord(dir.path()).value().key, SampleRecord().key);
  ASSERT_EQ(::truncate((dir.path() / kEntryRecordName).c_str(), kMaxEntryRecordBytes + 1), 0);
  const absl::Status oversized = ReadEntryRecord(dir.path()).status();
  EXPECT_EQ(oversized.code(), absl::StatusCode::kInvalidArgument) << oversized;
  EXPECT_NE(oversized.message().find("over the limit"), std::string::npos) << oversized;
}

TEST(ManifestSummary, ReadsProductAndViewCount) {
  const ManifestSummary ring = SummarizeManifest(
      R"({"product": "atlas", "layout": "ring-top", "frames": 3, "views": [{}, {}, {}, {}, {}, {}, {}, {}, {}]})");
  EXPECT_EQ(ring.product, "atlas");
  EXPECT_EQ(ring.view_count, 9u);
  const ManifestSummary cards = SummarizeManifest(R"({"product": "cards", "views": []})");
  EXPECT_EQ(cards.product, "cards");
  EXPECT_EQ(cards.view_count, 0u);
}

TEST(ManifestSummary, TellsTextureArraysFromAtlasesByTheirMapsShape) {
  const std::string views = R"("views": [{}, {}, {}, {}])";
  const ManifestSummary strip = SummarizeManifest(
      R"({"tile_size": 64, )" + views + R"(, "maps": [{"semantic": "albedo_alpha", "width": 64, "height": 256}]})");
  EXPECT_TRUE(strip.texture_array);
  const ManifestSummary atlas = SummarizeManifest(
      R"({"tile_size": 64, )" + views + R"(, "maps": [{"semantic": "albedo_alpha", "width": 128, "height": 128}]})");
  EXPECT_FALSE(atlas.texture_array);
  EXPECT_FALSE(SummarizeManifest(R"({"tile_size": 64, "views": [{}], "maps": "x"})").texture_array);
}

TEST(ManifestSummary, ReadsFieldsInAnyOrderAndALaterDuplicateWins) {
  // The maps before tile_size and views; views whose elements nest.
  const ManifestSummary strip = SummarizeManifest(
      R"({"maps": [7, {"semantic": "albedo_alpha", "extra": {"width": 1}, "width": 64, "height": 128}],)"
      R"( "views": [{"a": [1, {"b": 2}]}, [3]], "tile_size": 64, "product": "atlas"})");
  EXPECT_EQ(strip.view_count, 2u);
  EXPECT_TRUE(strip.texture_array);
  // A key given twice counts with its last value, as in a parsed document.
  const ManifestSummary twice = SummarizeManifest(
      R"({"product": "cards", "views": [{}, {}], "product": 7, "views": {"a": 1}, "tile_size": 64,)"
      R"( "tile_size": -64})");
  EXPECT_EQ(twice.product, "atlas");
  EXPECT_EQ(twice.view_count, 0u);
  EXPECT_FALSE(SummarizeManifest(R"({"tile_size": 64, "views": [{}, {}],)"
                                 R"( "maps": [{"semantic": "albedo_alpha", "width": 64, "height": 128}], "maps": []})")
                   .texture_array);
  // A document cut short says nothing, whatever came before the cut.
  const ManifestSummary cut = SummarizeManifest(R"({"product": "cards", "views": [{}, {})");
  EXPECT_EQ(cut.product, "atlas");
  EXPECT_EQ(cut.view_count, 0u);
}

TEST(ManifestSummary, MissingOrMistypedFieldsKeepTheDefaults) {
  // Manifests older than products are atlases.
  EXPECT_EQ(SummarizeManifest(R"({"views": [{}]})").product, "atlas");
  for (const char* json : {"", "not json", "[1, 2]", R"({"product": 7, "views": {"a": 1}})"}) {
    const ManifestSummary s = SummarizeManifest(json);
    EXPECT_EQ(s.product, "atlas") << json;
    EXPECT_EQ(s.view_count, 0u) << json;
  }
}

TEST(DownloadCoordinator, JoinersOfOneKeyShareOneRunAndDifferentKeysRunInParallel) {
  std::atomic<int> runs{0};
  std::latch both_running(2);  // proves two keys run at the same time
  DownloadCoordinator coordinator(2, 1, [&](const std::string& key, CancelSource&) -> DownloadCoordinator::Result {
    ++runs;
    both_running.arrive_and_wait();
    return absl::NotFoundError(key);
  });
  std::mutex mu;
  std::vector<std::string> answers;
  std::latch done(4);
  auto record = [&](const DownloadCoordinator::Result& r) {
    std::lock_guard lock(mu);
    answers.push_back(std::string(r.status().message()));
    done.count_down();
  };
  coordinator.Join("x", true, record);
  coordinator.Join("x", true, record);
  coordinator.Join("x", false, record);
  coordinator.Join("y", true, record);
  done.wait();
  EXPECT_EQ(runs.load(), 2);
  std::sort(answers.begin(), answers.end());
  EXPECT_EQ(answers, (std::vector<std::string>{"x", "x", "x", "y"}));
  coordinator.Shutdown();
  absl::StatusCode after = absl::StatusCode::kOk;
  coordinator.Join("z", true, [&](const DownloadCoordinator::Result& r) { after = r.status().code(); });
  EXPECT_EQ(after, absl::StatusCode::kCancelled);
}

// Once the last waiter of a flight has its result the coordinator holds no
// copy: a game's Get, released, leaves the entry unpinned at once, so a
// CollectGarbage or Stats right after sees it free. (Before, the pool thread
// kept its copy until its loop came round: pinned=1 in 2 of 8 runs.)
TEST(DownloadCoordinator, TheLastWaiterHoldsTheOnlyCopyOfTheResult) {
  auto pin = std::make_shared<EntryPin>();
  std::weak_ptr<EntryPin> watch = pin;
  DownloadCoordinator coordinator(1, 1, [&](const std::string&, CancelSource&) -> DownloadCoordinator::Result {
    auto rep = std::make_shared<CachedResult::Rep>();
    rep->pin = std::move(pin);
    return CachedResult(std::move(rep));
  });
  std::latch done(1);
  coordinator.Join("k", true, [&](DownloadCoordinator::Result r) {
    DownloadCoordinator::Result mine = std::move(r);
    mine = absl::CancelledError("released");
    EXPECT_TRUE(watch.expired()) << "the coordinator still holds the result";
    done.count_down();
  });
  done.wait();
  coordinator.Shutdown();
}

// Threads start as flights need them, and every flight that can run gets
// one at once: flights one after another run on one thread however large
// the pool, and four at once run on four. (A fleet of 100 caches held 2,000
// threads that never ran a flight, and each Join woke every idle one.)
TEST(DownloadCoordinator, ThreadsStartAsFlightsNeedThem) {
  std::mutex mu;
  std::condition_variable changed;
  std::set<std::thread::id> threads;
  int waiting = 0;  // flights inside the work, held there until `release`
  int release = 1;
  DownloadCoordinator coordinator(8, 8, [&](const std::string& key, CancelSource&) -> DownloadCoordinator::Result {
    std::unique_lock lock(mu);
    threads.insert(std::this_thread::get_id());
    ++waiting;
    changed.notify_all();
    // Bounded, so that a missing thread fails the test instead of hanging it.
    if (!changed.wait_for(lock, std::chrono::seconds(30), [&] { return waiting >= release; })) {
      return absl::DeadlineExceededError(key);
    }
    return absl::NotFoundError(key);
  });
  auto join_all = [&](const std::vector<std::string>& keys) {
    std::vector<std::promise<absl::StatusCode>> answers(keys.size());
    for (size_t i = 0; i < keys.size(); ++i) {
      coordinator.Join(keys[i], true, [&answers, i](DownloadCoordinator::Result r) { answers[i].set_value(r.status().code()); });
    }
    std::vector<absl::StatusCode> codes;
    for (auto& a : answers) codes.push_back(a.get_future().get());
    return codes;
  };
  for (const char* key : {"a", "b", "c"}) {
    {
      std::lock_guard lock(mu);
      waiting = 0;
      release = 1;
    }
    EXPECT_EQ(join_all({key}), std::vector<absl::StatusCode>{absl::StatusCode::kNotFound}) << key;
  }
  EXPECT_EQ(threads.size(), 1u) << "flights one after another";
  {
    std::lock_guard lock(mu);
    waiting = 0;
    release = 4;  // each flight waits until all four run
  }
  EXPECT_EQ(join_all({"d", "e", "f", "g"}), std::vector<absl::StatusCode>(4, absl::StatusCode::kNotFound))
      << "four flights did not run at once";
  EXPECT_EQ(threads.size(), 4u) << "threads for four flights at once";
  coordinator.Shutdown();
}

// A Cache closed from inside its own GetAsync callback destroys the
// coordinator on one of its pool threads: that thread is let go, the others
// are joined, and the flight's other waiters still get their answer. (It
// aborted with std::system_error "Resource deadlock avoided": the
// destructor joined the thread it ran on.)
TEST(DownloadCoordinator, AWaiterCallbackMayDestroyTheCoordinator) {
  std::latch both_joined(1);  // one flight with two waiters
  auto coordinator =
      std::make_unique<DownloadCoordinator>(2, 1, [&](const std::string& key, CancelSource&) -> DownloadCoordinator::Result {
        both_joined.wait();
        return absl::NotFoundError(key);
      });
  std::promise<absl::StatusCode> first, second;
  coordinator->Join("k", true, [&](DownloadCoordinator::Result r) {
    coordinator.reset();
    first.set_value(r.status().code());
  });
  coordinator->Join("k", true, [&](DownloadCoordinator::Result r) { second.set_value(r.status().code()); });
  both_joined.count_down();
  auto first_done = first.get_future(), second_done = second.get_future();
  ASSERT_EQ(first_done.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  ASSERT_EQ(second_done.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  EXPECT_EQ(first_done.get(), absl::StatusCode::kNotFound);
  EXPECT_EQ(second_done.get(), absl::StatusCode::kNotFound);
  EXPECT_EQ(coordinator, nullptr);
}

// The same for the I/O pool (a hit's callback): with one thread, what is
// still queued when a task drains and destroys the queue runs at once, on
// that thread, exactly once; later posts run on the poster.
TEST(WorkQueue, ATaskMayDrainAndDestroyTheQueue) {
  auto queue = std::make_unique<WorkQueue>(1);
  std::latch second_posted(1);
  std::promise<void> first_done;
  std::atomic<int> second_runs{0};
  queue->Post([&] {
    second_posted.wait();
    queue.reset();
    first_done.set_value();
  });
  queue->Post([&] { ++second_runs; });
  second_posted.count_down();
  auto done = first_done.get_future();
  ASSERT_EQ(done.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  EXPECT_EQ(second_runs.load(), 1) << "a task queued behind the draining one was lost or run twice";
  EXPECT_EQ(queue, nullptr);
}

// A reader serving `bytes` and checking the whole blob's digest, as a
// mirror's or the farm's does.
BlobReader ReaderOf(std::string bytes) {
  return [bytes = std::move(bytes)](const v1::Digest& digest, int64_t offset, Sha256& hash,
                                    const std::function<absl::Status(std::string_view)>& sink,
                                    const CancelSource*) -> absl::Status {
    const std::string_view rest = std::string_view(bytes).substr(static_cast<size_t>(offset));
    hash.Update(rest);
    if (absl::Status s = sink(rest); !s.ok()) return s;
    return hash.FinishHex() == digest.hash() ? absl::OkStatus() : absl::DataLossError("digest mismatch");
  };
}

// FetchBlob leaves the blob's file open and unlocked (BlobOutcome::file):
// the install syncs it and removes the partial through it. That removal
// leaves a partial another download holds, and a name that now holds
// another file, alone.
TEST(PartialDownload, TheKeptFileIsUnlockedAndRemovesOnlyItsOwnUnheldPartial) {
  std::string pattern = (std::filesystem::temp_directory_path() / "partial_kept_open.XXXXXX").string();
  ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
  const std::filesystem::path dir = pattern;
  const std::string bytes(70000, 'x');
  v1::Digest digest;
  digest.set_hash(Sha256Hex(bytes));
  digest.set_size_bytes(static_cast<int64_t>(bytes.size()));
  const std::filesystem::path partial = dir / "blob.part";
  auto fetch = [&](const std::string& link) {
    return FetchBlob(ReaderOf(bytes), digest, partial, {dir / link}, DownloadHooks{}, nullptr);
  };

  absl::StatusOr<BlobOutcome> first = fetch("a");
  ASSERT_TRUE(first.ok()) << first.status();
  ASSERT_TRUE(first->file.valid());
  EXPECT_TRUE(first->shared);
  EXPECT_EQ(std::filesystem::file_size(dir / "a"), bytes.size());
  {
    // Another download of the blob may lock the partial at once.
    const UniqueFd other(::open(partial.c_str(), O_RDONLY | O_CLOEXEC));
    ASSERT_TRUE(other.valid());
    EXPECT_EQ(::flock(other.get(), LOCK_EX | LOCK_NB), 0) << "the kept file still holds the partial's lock";
    // ...and while it does, the cleanup leaves the partial to it.
    EXPECT_FALSE(RemoveOpenPartialIfUnused(partial, std::move(first->file), first->identity));
    EXPECT_TRUE(std::filesystem::exists(partial));
  }

  // The partial's name now holds another file: not removed.
  absl::StatusOr<BlobOutcome> third = fetch("c");
  ASSERT_TRUE(third.ok()) << third.status();
  std::filesystem::rename(dir / "c", dir / "c.kept");
  std::filesystem::remove(partial);
  std::ofstream(partial) << "another file";
  EXPECT_FALSE(RemoveOpenPartialIfUnused(partial, std::move(third->file), third->identity));
  EXPECT_TRUE(std::filesystem::exists(partial));

  // Unheld and still its own: removed, the linked copy kept.
  std::filesystem::remove(partial);
  absl::StatusOr<BlobOutcome> fourth = fetch("d");
  ASSERT_TRUE(fourth.ok()) << fourth.status();
  EXPECT_TRUE(RemoveOpenPartialIfUnused(partial, std::move(fourth->file), fourth->identity));
  EXPECT_FALSE(std::filesystem::exists(partial));
  EXPECT_EQ(std::filesystem::file_size(dir / "d"), bytes.size());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace impostor::sdk
