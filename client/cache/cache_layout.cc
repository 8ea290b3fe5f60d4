#include "client/cache/cache_layout.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "client/base/local_io_error.h"
#include "client/base/small_file.h"
#include "common/util/sha256.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

constexpr char kFormatFileName[] = "FORMAT";
constexpr char kFormatText[] = "impostor-cache 1\n";

bool IsPlainName(const std::string& name) {
  return !name.empty() && name != "." && name != ".." && name != kEntryRecordName &&
         name.find('/') == std::string::npos && name.find('\0') == std::string::npos;
}

int64_t MtimeNs(const struct stat& st) {
  return static_cast<int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
}

}  // namespace

int64_t EntryRecord::TotalBytes() const {
  int64_t total = 0;
  for (const EntryFile& f : files) total += f.size_bytes;
  return total;
}

bool IsCacheKey(std::string_view key) { return IsSha256Hex(key); }

fs::path CacheLayout::PartialPath(std::string_view sha256, int64_t size_bytes) const {
  return PartialDir() / absl::StrCat(std::string(sha256), "-", size_bytes, ".part");
}

absl::Status CacheLayout::Init() const {
  for (const fs::path& dir : {root_, EntriesDir(), StagingDir(), PartialDir()}) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec || !fs::is_directory(dir)) {
      return absl::InternalError(absl::StrCat("cache directory ", dir.string(), " is unusable: ",
                                              ec ? ec.message() : std::string("not a directory")));
    }
  }
  const fs::path format = root_ / kFormatFileName;
  std::ifstream in(format, std::ios::binary);
  if (in) {
    std::stringstream text;
    text << in.rdbuf();
    if (text.str() != kFormatText) {
      return absl::InternalError(absl::StrCat(format.string(), ": not an impostor cache of format 1 (found \"",
                                              text.str().substr(0, 40), "\"); use another directory"));
    }
    return absl::OkStatus();
  }
  // Written through a rename so that a reader never sees it half-written.
  // One name per call: threads of a process may rebuild the layout at once.
  static std::atomic<uint64_t> calls{0};
  const fs::path temp = root_ / absl::StrCat(".FORMAT.", ::getpid(), ".", calls.fetch_add(1));
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out << kFormatText;
    if (!out.flush()) return LocalIoError("cannot write", temp, errno);
  }
  if (::rename(temp.c_str(), format.c_str()) != 0) {
    const int err = errno;
    ::unlink(temp.c_str());
    return LocalIoError("cannot create", format, err);
  }
  return absl::OkStatus();
}

bool CacheLayout::Intact() const {
  struct stat st;
  for (const fs::path& dir : {EntriesDir(), StagingDir(), PartialDir()}) {
    if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) return false;
  }
  return ::stat((root_ / kFormatFileName).c_str(), &st) == 0;
}

std::vector<std::string> CacheLayout::ListEntryKeys() const {
  std::vector<std::string> keys;
  std::error_code ec;
  for (fs::directory_iterator it(EntriesDir(), ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (IsCacheKey(name)) keys.push_back(name);
  }
  return keys;
}

std::string EntryRecordToJson(const EntryRecord& record) {
  nlohmann::json files = nlohmann::json::array();
  for (const EntryFile& f : record.files) {
    files.push_back({{"semantic", f.semantic},
                     {"name", f.name},
                     {"sha256", f.sha256},
                     {"size_bytes", f.size_bytes},
                     {"width", f.width},
                     {"height", f.height},
                     {"format", f.format},
                     {"inode", f.inode},
                     {"mtime_ns", f.mtime_ns}});
  }
  nlohmann::json j = {{"format", 1},
                      {"key", record.key},
                      {"layout", record.layout},
                      {"frames", record.frames},
                      {"resolution", record.resolution},
                      {"files", files}};
  return j.dump(2) + "\n";
}

absl::StatusOr<EntryRecord> EntryRecordFromJson(std::string_view json) {
  const nlohmann::json j = nlohmann::json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return absl::InvalidArgumentError(".entry: not a JSON object");
  try {
    if (j.at("format").get<int>() != 1) return absl::InvalidArgumentError(".entry: unknown format");
    EntryRecord r;
    r.key = j.at("key").get<std::string>();
    if (!IsCacheKey(r.key)) return absl::InvalidArgumentError(".entry: key is not a cache key");
    r.layout = j.at("layout").get<std::string>();
    r.frames = j.at("frames").get<uint32_t>();
    r.resolution = j.at("resolution").get<uint32_t>();
    for (const nlohmann::json& jf : j.at("files")) {
      EntryFile f;
      f.semantic = jf.at("semantic").get<std::string>();
      f.name = jf.at("name").get<std::string>();
      f.sha256 = jf.at("sha256").get<std::string>();
      f.size_bytes = jf.at("size_bytes").get<int64_t>();
      f.width = jf.at("width").get<uint32_t>();
      f.height = jf.at("height").get<uint32_t>();
      f.format = jf.at("format").get<std::string>();
      f.inode = jf.at("inode").get<uint64_t>();
      f.mtime_ns = jf.at("mtime_ns").get<int64_t>();
      if (!IsPlainName(f.name)) return absl::InvalidArgumentError(".entry: file name is not plain: " + f.name);
      if (!ValidateDigest("sha256", f.sha256, f.size_bytes).ok()) {
        return absl::InvalidArgumentError(".entry: bad digest for " + f.name);
      }
      r.files.push_back(std::move(f));
    }
    if (r.files.empty()) return absl::InvalidArgumentError(".entry: no files");
    return r;
  } catch (const nlohmann::json::exception& e) {
    return absl::InvalidArgumentError(absl::StrCat(".entry: ", e.what()));
  }
}

absl::StatusOr<EntryRecord> ReadEntryRecord(const fs::path& dir) {
  const fs::path path = dir / kEntryRecordName;
  absl::StatusOr<std::string> text = ReadSmallFile(path, kMaxEntryRecordBytes);
  if (!text.ok()) {
    // Over the limit: not a record of ours.
    if (absl::IsOutOfRange(text.status())) return absl::InvalidArgumentError(text.status().message());
    return text.status();
  }
  absl::StatusOr<EntryRecord> record = EntryRecordFromJson(*text);
  if (!record.ok()) return absl::InvalidArgumentError(absl::StrCat(path.string(), ": ", record.status().message()));
  return record;
}

absl::Status RecordFileIdentities(const fs::path& dir, EntryRecord& record) {
  for (EntryFile& f : record.files) {
    struct stat st;
    const fs::path path = dir / f.name;
    if (::stat(path.c_str(), &st) != 0) return LocalIoError("cannot stat", path, errno);
    f.inode = st.st_ino;
    f.mtime_ns = MtimeNs(st);
  }
  return absl::OkStatus();
}

absl::Status CheckEntryFiles(const fs::path& dir, EntryRecord& record, FileCheck check) {
  for (EntryFile& f : record.files) {
    const fs::path path = dir / f.name;
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) {
      if (errno == ENOENT || errno == ENOTDIR) return absl::NotFoundError(absl::StrCat(path.string(), ": missing"));
      return LocalIoError("cannot stat", path, errno);
    }
    if (static_cast<int64_t>(st.st_size) != f.size_bytes) {
      return absl::DataLossError(
          absl::StrCat(path.string(), ": ", st.st_size, " bytes on disk, expected ", f.size_bytes));
    }
    const bool changed = st.st_ino != f.inode || MtimeNs(st) != f.mtime_ns;
    if (check == FileCheck::kMetadata && !changed) continue;
    absl::StatusOr<BlobDigest> digest = DigestFile(path);
    if (!digest.ok()) return digest.status();
    if (digest->hash != f.sha256 || digest->size_bytes != f.size_bytes) {
      return absl::DataLossError(absl::StrCat(path.string(), ": content hashes to ", digest->hash, ", expected ",
                                              f.sha256));
    }
    f.inode = st.st_ino;
    f.mtime_ns = MtimeNs(st);
  }
  return absl::OkStatus();
}

int64_t EntryLastUsed(const fs::path& dir) {
  struct stat st;
  if (::stat(dir.c_str(), &st) != 0) return 0;
  return static_cast<int64_t>(st.st_mtim.tv_sec);
}

void TouchEntry(const fs::path& dir) {
  // Best effort: a failed touch only makes LRU order after a restart a
  // little less accurate.
  ::utimensat(AT_FDCWD, dir.c_str(), nullptr, 0);
}

absl::Status RemoveEntryDir(const CacheLayout& layout, const fs::path& dir) {
  static std::atomic<uint64_t> counter{0};
  const fs::path trash = layout.StagingDir() / absl::StrCat("trash-", ::getpid(), "-", counter.fetch_add(1), "-",
                                                            dir.filename().string());
  if (::rename(dir.c_str(), trash.c_str()) != 0) {
    if (errno == ENOENT) return absl::OkStatus();
    return LocalIoError(absl::StrCat("cannot move ", dir.string(), " to"), trash, errno);
  }
  std::error_code ec;
  fs::remove_all(trash, ec);  // leftovers are collected by garbage collection
  return absl::OkStatus();
}

absl::Status SyncDir(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return LocalIoError("cannot open", dir, errno);
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) return LocalIoError("cannot sync", dir, err);
  return absl::OkStatus();
}

}  // namespace impostor::sdk
