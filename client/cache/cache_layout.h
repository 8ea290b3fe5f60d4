// The on-disk layout of the result cache (spec: cache_layout.md): where
// entries, staging directories and partial downloads live, the `.entry`
// record of an installed result, and the checks that an installed result is
// intact. No state beyond the root path; thread-safe. Files may be changed
// by other processes at any time, so every reader copes with them vanishing.
#ifndef IMPOSTOR_CLIENT_CACHE_CACHE_LAYOUT_H_
#define IMPOSTOR_CLIENT_CACHE_CACHE_LAYOUT_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor::sdk {

// One file of an installed result, as recorded in its `.entry`.
struct EntryFile {
  std::string semantic;  // map semantic, or "manifest"
  std::string name;      // plain file name inside the entry directory
  std::string sha256;
  int64_t size_bytes = 0;
  uint32_t width = 0;
  uint32_t height = 0;
  std::string format;
  // Identity of the file when it was installed: a hit compares them with
  // stat() to notice a file replaced or rewritten behind the cache's back.
  uint64_t inode = 0;
  int64_t mtime_ns = 0;
};

// The `.entry` record: everything a hit needs without reading manifest.json.
struct EntryRecord {
  std::string key;
  std::string layout;
  uint32_t frames = 0;
  uint32_t resolution = 0;
  // Maps in manifest order, then manifest.json.
  std::vector<EntryFile> files;

  int64_t TotalBytes() const;
};

inline constexpr char kEntryRecordName[] = ".entry";
// An entry record larger than this is not one this library wrote (a
// result's record is a few KiB): it is treated as unreadable.
inline constexpr int64_t kMaxEntryRecordBytes = int64_t{16} << 20;
// A result's manifest.json, read into memory for every entry's view; its
// digest was checked when it was installed.
inline constexpr int64_t kMaxManifestBytes = int64_t{256} << 20;

class CacheLayout {
 public:
  explicit CacheLayout(std::filesystem::path root)
      : root_(std::move(root)),
        entries_dir_(root_ / "entries"),
        staging_dir_(root_ / "staging"),
        partial_dir_(root_ / "partial") {}

  // Creates the directories and the FORMAT file, or checks that an existing
  // FORMAT names this version. INTERNAL naming the path otherwise.
  absl::Status Init() const;
  // True when the directories and the FORMAT file are all there (a few
  // stat calls): false after someone deleted the cache directory, or part
  // of it, under a running cache; Init then rebuilds it.
  bool Intact() const;

  const std::filesystem::path& root() const { return root_; }
  // Built once: a Get that misses asks for them several times, and each
  // path built from parts is parsed again (1 % of a fleet's CPU).
  const std::filesystem::path& EntriesDir() const { return entries_dir_; }
  const std::filesystem::path& StagingDir() const { return staging_dir_; }
  const std::filesystem::path& PartialDir() const { return partial_dir_; }
  std::filesystem::path EntryDir(std::string_view key) const { return entries_dir_ / key; }
  std::filesystem::path PartialPath(std::string_view sha256, int64_t size_bytes) const;

  // Keys of the directories under entries/ (names that are cache keys).
  std::vector<std::string> ListEntryKeys() const;

 private:
  std::filesystem::path root_;
  std::filesystem::path entries_dir_;
  std::filesystem::path staging_dir_;
  std::filesystem::path partial_dir_;
};

// True for 64 lowercase hex characters.
bool IsCacheKey(std::string_view key);

std::string EntryRecordToJson(const EntryRecord& record);
// INVALID_ARGUMENT naming the field; every file name must be plain.
absl::StatusOr<EntryRecord> EntryRecordFromJson(std::string_view json);
// Reads dir/.entry. NOT_FOUND when absent, INTERNAL / INVALID_ARGUMENT
// when unreadable.
absl::StatusOr<EntryRecord> ReadEntryRecord(const std::filesystem::path& dir);

// Fills each file's inode and mtime from the files in `dir`.
absl::Status RecordFileIdentities(const std::filesystem::path& dir, EntryRecord& record);

// How far CheckEntryFiles goes.
enum class FileCheck {
  kMetadata,  // size must match; a changed inode or mtime means re-hash
  kDigest,    // re-hash every file
};

// OK when every file of `record` is in `dir` and intact; NOT_FOUND when a
// file (or the directory) is gone; DATA_LOSS naming the file when its size
// or digest differs. Updates the identities in `record` of files whose
// metadata changed but whose bytes still match.
absl::Status CheckEntryFiles(const std::filesystem::path& dir, EntryRecord& record, FileCheck check);

// Last use as stored in the entry directory's mtime, Unix seconds (0 when
// unreadable); TouchEntry sets it to now.
int64_t EntryLastUsed(const std::filesystem::path& dir);
void TouchEntry(const std::filesystem::path& dir);

// Moves `dir` into staging/ under a unique name, then deletes it, so that no
// one ever sees a half-deleted entry under its key. Holders of open files
// keep reading them. INTERNAL when the move fails (a vanished dir is OK).
absl::Status RemoveEntryDir(const CacheLayout& layout, const std::filesystem::path& dir);

// fsync of a directory, so a rename into it survives a crash.
absl::Status SyncDir(const std::filesystem::path& dir);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_CACHE_LAYOUT_H_
