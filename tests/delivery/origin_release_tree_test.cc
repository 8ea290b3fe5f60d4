// ReleaseTree (server/http/release_files.h) on a tree in a temporary
// folder: opening a release directory, opening files without following
// links, and the integrity check: once per file version, shared by
// concurrent first requests, corrupt files refused and remembered, bounded.
#include <sys/stat.h>

#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "server/http/release_files.h"
#include "tests/delivery/origin_tree_writer.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::TempReleaseTree;

ReleasePath PathOf(const std::string& relative) {
  auto parsed = ParseReleasePath(relative);
  EXPECT_TRUE(parsed.has_value()) << relative;
  return parsed.value_or(ReleasePath{});
}

// `n` bytes that differ from blob to blob.
std::string BytesOf(size_t n, char seed) {
  std::string bytes(n, '\0');
  for (size_t i = 0; i < n; ++i) bytes[i] = static_cast<char>(seed + i * 31 + (i >> 7));
  return bytes;
}

TEST(ReleaseTreeTest, OpenRefusesWhatIsNotAReleaseTreeNamingThePath) {
  TempReleaseTree tree("open");
  const fs::path file = tree.dir() / "a_file";
  tree.Write("../a_file", "x");
  const fs::path empty = tree.dir() / "empty";
  fs::create_directories(empty);
  struct Case {
    fs::path root;
    std::string says;
  };
  for (const Case& c : {Case{tree.dir() / "missing", "no such directory"}, Case{file, "not a directory"},
                        Case{empty, "has no v1/ directory"}}) {
    auto opened = ReleaseTree::Open(c.root);
    ASSERT_FALSE(opened.ok()) << c.root;
    EXPECT_TRUE(absl::IsInvalidArgument(opened.status())) << opened.status();
    EXPECT_NE(opened.status().message().find(c.root.string()), std::string::npos) << opened.status();
    EXPECT_NE(opened.status().message().find(c.says), std::string::npos) << opened.status();
  }
  EXPECT_TRUE(ReleaseTree::Open(tree.root()).ok());
}

TEST(ReleaseTreeTest, OpensFilesOnlyWithoutLinksAndOnlyRegularOnes) {
  TempReleaseTree tree("links");
  const std::string present = tree.AddBlob("present");
  auto opened = ReleaseTree::Open(tree.root());
  ASSERT_TRUE(opened.ok()) << opened.status();
  ReleaseTree& releases = **opened;

  auto file = releases.OpenFile(PathOf(TempReleaseTree::BlobPath(present)));
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_EQ(file->size_bytes(), 7);
  std::string bytes;
  ASSERT_TRUE(file->ReadAt(2, 100, bytes).ok());
  EXPECT_EQ(bytes, "esent");

  // A secret beside the tree, and links to it named by its digest.
  const std::string secret = "not for the release tree";
  const std::string secret_hex = Sha256Hex(secret);
  {
    std::ofstream out(tree.outside() / secret_hex);
    out << secret;
  }
  fs::create_directories(tree.root() / "v1/blobs/sha256" / secret_hex.substr(0, 2));
  fs::create_symlink(tree.outside() / secret_hex, tree.root() / TempReleaseTree::BlobPath(secret_hex));
  fs::create_directories(tree.root() / "v1/catalogs/sha256");
  fs::create_symlink(tree.outside(), tree.root() / "v1/catalogs/sha256" / secret_hex.substr(0, 2));
  // A link that stays inside the tree is not followed either.
  const std::string inside = tree.AddBlob("inside");
  fs::create_directories(tree.root() / "v1/channels");
  fs::create_symlink(tree.root() / TempReleaseTree::BlobPath(inside), tree.root() / "v1/channels/linked.json");
  // Not regular files.
  ASSERT_EQ(::mkfifo((tree.root() / "v1/channels/fifo.json").c_str(), 0644), 0);
  fs::create_directories(tree.root() / "v1/channels/folder.json");

  struct Case {
    std::string what;
    std::string relative;
  };
  const std::vector<Case> cases = {
      {"missing blob", TempReleaseTree::BlobPath(Sha256Hex("absent"))},
      {"missing channel", TempReleaseTree::ChannelPath("absent")},
      {"link to a file out of the tree", TempReleaseTree::BlobPath(secret_hex)},
      {"link to a folder out of the tree", TempReleaseTree::CatalogPath(secret_hex)},
      {"link inside the tree", TempReleaseTree::ChannelPath("linked")},
      {"FIFO", TempReleaseTree::ChannelPath("fifo")},
      {"folder", TempReleaseTree::ChannelPath("folder")},
  };
  for (const Case& c : cases) {
    auto refused = releases.OpenFile(PathOf(c.relative));
    ASSERT_FALSE(refused.ok()) << c.what;
    EXPECT_TRUE(absl::IsNotFound(refused.status())) << c.what << ": " << refused.status();
  }
}

TEST(ReleaseTreeTest, ChecksEachVersionOfAFileOnceAndRefusesACorruptOne) {
  TempReleaseTree tree("verify");
  const std::string good = tree.AddBlob(BytesOf(300000, 'a'));
  // Named after other bytes than it holds.
  const std::string named = Sha256Hex("the published bytes");
  tree.Write(TempReleaseTree::BlobPath(named), "tampered bytes");
  auto opened = ReleaseTree::Open(tree.root());
  ASSERT_TRUE(opened.ok()) << opened.status();
  ReleaseTree& releases = **opened;

  const ReleasePath good_path = PathOf(TempReleaseTree::BlobPath(good));
  for (int i = 0; i < 3; ++i) {
    auto file = releases.OpenFile(good_path);
    ASSERT_TRUE(file.ok()) << file.status();
    EXPECT_TRUE(releases.Verify(good_path, *file).ok());
  }
  EXPECT_EQ(releases.verification_reads(), 1);

  const ReleasePath corrupt_path = PathOf(TempReleaseTree::BlobPath(named));
  for (int i = 0; i < 2; ++i) {
    auto file = releases.OpenFile(corrupt_path);
    ASSERT_TRUE(file.ok()) << file.status();
    const absl::Status s = releases.Verify(corrupt_path, *file);
    EXPECT_TRUE(absl::IsDataLoss(s)) << s;
    EXPECT_NE(s.message().find(corrupt_path.relative), std::string::npos) << s;
    EXPECT_NE(s.message().find(named), std::string::npos) << s;
    EXPECT_NE(s.message().find(Sha256Hex("tampered bytes")), std::string::npos) << s;
  }
  EXPECT_EQ(releases.verification_reads(), 2) << "a corrupt file is remembered too";

  // Published again (a new file renamed over it): checked again, now good.
  tree.Write(TempReleaseTree::BlobPath(named) + ".new", "the published bytes");
  fs::rename(tree.root() / (TempReleaseTree::BlobPath(named) + ".new"), tree.root() / corrupt_path.relative);
  auto file = releases.OpenFile(corrupt_path);
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_TRUE(releases.Verify(corrupt_path, *file).ok());
  EXPECT_EQ(releases.verification_reads(), 3);

  // Rewritten in place (a new size and mtime, same inode): checked again.
  tree.Write(good_path.relative, "rotten");
  file = releases.OpenFile(good_path);
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_TRUE(absl::IsDataLoss(releases.Verify(good_path, *file)));
  EXPECT_EQ(releases.verification_reads(), 4);
}

TEST(ReleaseTreeTest, ConcurrentFirstRequestsShareOneRead) {
  TempReleaseTree tree("single_flight");
  const std::string hex = tree.AddBlob(BytesOf(1 << 20, 'z'));
  constexpr int kThreads = 8;
  std::mutex mu;
  std::condition_variable arrived;
  int readers = 0;
  int waiters = 0;
  // The thread that reads holds its read until every thread has either
  // joined it or (were there no single flight) started a read of its own.
  ReleaseTree::Options options;
  options.on_verify = [&](bool reads, std::string_view) {
    std::unique_lock lock(mu);
    ++(reads ? readers : waiters);
    arrived.notify_all();
    if (reads) arrived.wait(lock, [&] { return readers + waiters == kThreads; });
  };
  auto opened = ReleaseTree::Open(tree.root(), options);
  ASSERT_TRUE(opened.ok()) << opened.status();
  ReleaseTree& releases = **opened;
  const ReleasePath path = PathOf(TempReleaseTree::BlobPath(hex));

  std::vector<absl::Status> results(kThreads);
  {
    std::vector<std::jthread> threads;
    for (int i = 0; i < kThreads; ++i) {
      threads.emplace_back([&, i] {
        auto file = releases.OpenFile(path);
        results[i] = file.ok() ? releases.Verify(path, *file) : file.status();
      });
    }
  }
  for (int i = 0; i < kThreads; ++i) EXPECT_TRUE(results[i].ok()) << "thread " << i << ": " << results[i];
  EXPECT_EQ(readers, 1);
  EXPECT_EQ(waiters, kThreads - 1);
  EXPECT_EQ(releases.verification_reads(), 1);
}

TEST(ReleaseTreeTest, RemembersABoundedNumberOfFiles) {
  TempReleaseTree tree("bounded");
  std::vector<ReleasePath> paths;
  for (const char* bytes : {"one", "two", "three"}) {
    paths.push_back(PathOf(TempReleaseTree::BlobPath(tree.AddBlob(bytes))));
  }
  ReleaseTree::Options options;
  options.max_remembered = 2;
  auto opened = ReleaseTree::Open(tree.root(), options);
  ASSERT_TRUE(opened.ok()) << opened.status();
  ReleaseTree& releases = **opened;
  auto verify = [&](const ReleasePath& path) {
    auto file = releases.OpenFile(path);
    ASSERT_TRUE(file.ok()) << file.status();
    EXPECT_TRUE(releases.Verify(path, *file).ok()) << path.relative;
  };
  verify(paths[0]);
  verify(paths[1]);
  verify(paths[0]);  // now the most recent: paths[1] goes first
  verify(paths[2]);
  EXPECT_EQ(releases.verification_reads(), 3);
  verify(paths[0]);
  EXPECT_EQ(releases.verification_reads(), 3) << "the most recently used file was forgotten";
  verify(paths[1]);
  EXPECT_EQ(releases.verification_reads(), 4) << "the least recently used file was remembered";

  ReleaseTree::Options none;
  none.max_remembered = 0;
  EXPECT_TRUE(absl::IsInvalidArgument(ReleaseTree::Open(tree.root(), none).status()));
}

TEST(ReleaseTreeTest, ReadAllRefusesAFileOverItsLimit) {
  TempReleaseTree tree("read_all");
  tree.SetChannel("nightly", "{\"channel\":\"nightly\"}");
  auto opened = ReleaseTree::Open(tree.root());
  ASSERT_TRUE(opened.ok()) << opened.status();
  auto file = (*opened)->OpenFile(PathOf(TempReleaseTree::ChannelPath("nightly")));
  ASSERT_TRUE(file.ok()) << file.status();
  auto all = file->ReadAll(1000);
  ASSERT_TRUE(all.ok()) << all.status();
  EXPECT_EQ(*all, "{\"channel\":\"nightly\"}");
  EXPECT_TRUE(absl::IsFailedPrecondition(file->ReadAll(5).status()));
}

}  // namespace
}  // namespace impostor
