#include "client/delivery/publisher.h"

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "absl/strings/string_view.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "client/base/atomic_file.h"
#include "client/transfer/blob_download.h"
#include "client/delivery/catalog.h"
#include "client/delivery/catalog_signature.h"
#include "client/delivery/release_paths.h"
#include "client/base/local_io_error.h"
#include "client/base/sdk_log.h"
#include "common/util/sha256.h"
#include "nlohmann/json.hpp"

namespace impostor::delivery {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::optional<std::string> ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

absl::Status WriteFileAtomically(const fs::path& path, std::string_view bytes) {
  absl::StatusOr<std::unique_ptr<sdk::AtomicFileWriter>> writer = sdk::AtomicFileWriter::Create(path);
  if (!writer.ok()) return writer.status();
  if (absl::Status s = (*writer)->Append(bytes); !s.ok()) return s;
  return (*writer)->Commit();
}

absl::Status MakeDirs(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return sdk::LocalIoError("cannot create", dir, ec.value());
  return absl::OkStatus();
}

// Makes every rename so far durable (one syncfs for the whole tree's file
// system): what a later step names must survive a crash before it does.
absl::Status SyncTree(const fs::path& root) {
  const int fd = ::open(root.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return sdk::LocalIoError("cannot open", root, errno);
  const int rc = ::syncfs(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) return sdk::LocalIoError("cannot sync", root, err);
  return absl::OkStatus();
}

int64_t NowUnix() {
  return std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

absl::StatusOr<int64_t> SourceDateEpoch() {
  const char* env = std::getenv("SOURCE_DATE_EPOCH");
  if (env == nullptr || env[0] == '\0') return NowUnix();
  int64_t t = 0;
  if (!absl::SimpleAtoi(env, &t) || t < 0) {
    return absl::InvalidArgumentError(absl::StrCat("SOURCE_DATE_EPOCH: expected Unix seconds, got \"", env, "\""));
  }
  return t;
}

// Whether the blob at `path` holds exactly `hex` / `size` (a publish that
// died mid-rename leaves nothing there; a damaged tree is repaired).
bool BlobIntact(const fs::path& path, const std::string& hex, int64_t size) {
  std::error_code ec;
  if (fs::file_size(path, ec) != static_cast<uintmax_t>(size) || ec) return false;
  absl::StatusOr<BlobDigest> digest = DigestFile(path);
  return digest.ok() && digest->hash == hex;
}

std::string StemOf(const std::string& path) {
  std::string stem = fs::path(path).stem().string();
  return stem.empty() ? path : stem;
}

}  // namespace

absl::StatusOr<std::vector<PublishEntry>> EntriesFromArguments(const std::vector<std::string>& inputs) {
  std::vector<PublishEntry> out;
  for (const std::string& input : inputs) {
    PublishEntry e;
    const size_t eq = input.rfind('=');
    if (eq == std::string::npos) {
      e.name = input;
      e.cache_key = input;
    } else {
      e.name = input.substr(0, eq);
      e.cache_key = input.substr(eq + 1);
    }
    if (!IsSha256Hex(e.cache_key)) {
      return absl::InvalidArgumentError(absl::StrCat("\"", input.substr(0, 100),
                                                     "\": expected a cache key (64 lowercase hex) or NAME=KEY"));
    }
    if (absl::Status s = ValidateAssetName(e.name); !s.ok()) return s;
    out.push_back(std::move(e));
  }
  return out;
}

absl::StatusOr<std::vector<PublishEntry>> EntriesFromBatchReport(absl::string_view text, absl::string_view source) {
  std::vector<json> lines;
  json whole = json::parse(text, nullptr, false);
  if (!whole.is_discarded() && whole.is_array()) {
    for (json& j : whole) lines.push_back(std::move(j));
  } else {
    int number = 0;
    for (absl::string_view line : absl::StrSplit(text, '\n')) {
      ++number;
      line = absl::StripAsciiWhitespace(line);
      if (line.empty()) continue;
      json j = json::parse(line, nullptr, false);
      if (j.is_discarded() || !j.is_object()) {
        return absl::InvalidArgumentError(
            absl::StrCat(source, ":", number, ": not a JSON object (expected `impostor bake-batch --json` output)"));
      }
      lines.push_back(std::move(j));
    }
  }
  std::vector<PublishEntry> out;
  for (const json& j : lines) {
    if (!j.is_object() || j.value("type", "") != "asset") continue;
    const std::string asset = j.contains("asset") && j["asset"].is_string() ? j["asset"].get<std::string>() : "";
    std::string name = j.contains("name") && j["name"].is_string() ? j["name"].get<std::string>() : "";
    if (name.empty()) name = StemOf(asset);
    const std::string status = j.value("status", "");
    if (status != "succeeded") {
      return absl::FailedPreconditionError(absl::StrCat(source, ": asset \"", name.substr(0, 100), "\" (", asset,
                                                        ") did not bake (status ", status.substr(0, 20),
                                                        "); a release is not published without it"));
    }
    PublishEntry e;
    e.name = name;
    e.cache_key = j.contains("cache_key") && j["cache_key"].is_string() ? j["cache_key"].get<std::string>() : "";
    if (!IsSha256Hex(e.cache_key)) {
      return absl::InvalidArgumentError(absl::StrCat(source, ": asset \"", name.substr(0, 100), "\" has no cache_key"));
    }
    if (absl::Status s = ValidateAssetName(e.name, absl::StrCat(source, ": asset name")); !s.ok()) return s;
    out.push_back(std::move(e));
  }
  if (out.empty()) return absl::InvalidArgumentError(absl::StrCat(source, ": lists no asset"));
  return out;
}

absl::StatusOr<PublishReport> Publish(sdk::Transport& transport, const std::vector<PublishEntry>& entries,
                                      const PublishOptions& options) {
  if (absl::Status s = ValidateChannelName(options.channel, "--channel"); !s.ok()) return s;
  if (entries.empty()) return absl::InvalidArgumentError("nothing to publish: give cache keys, NAME=KEY or --from-report");
  std::map<std::string, std::string> keys_by_name;
  for (const PublishEntry& e : entries) {
    if (absl::Status s = ValidateAssetName(e.name); !s.ok()) return s;
    auto [it, added] = keys_by_name.emplace(e.name, e.cache_key);
    if (!added && it->second != e.cache_key) {
      return absl::InvalidArgumentError(absl::StrCat("asset name \"", e.name, "\" is given two results: ", it->second,
                                                     " and ", e.cache_key));
    }
  }

  PublishReport report;
  Catalog catalog;
  std::set<std::string> baker_versions;
  // name -> asset; one farm request per distinct key.
  std::map<std::string, CatalogAsset> by_key;
  for (const auto& [name, key] : keys_by_name) {
    auto found = by_key.find(key);
    if (found == by_key.end()) {
      absl::StatusOr<v1::Manifest> manifest = transport.GetResult(key);
      if (!manifest.ok()) {
        if (absl::IsNotFound(manifest.status())) {
          return absl::NotFoundError(absl::StrCat("asset \"", name, "\": the farm has no result under ", key));
        }
        return absl::Status(manifest.status().code(),
                            absl::StrCat("asset \"", name, "\" (", key, "): ", manifest.status().message()));
      }
      if (!manifest->cache_key().empty() && manifest->cache_key() != key) {
        return absl::DataLossError(absl::StrCat("asset \"", name, "\": the farm answered ", key, " with the result of ",
                                                manifest->cache_key().substr(0, 64)));
      }
      manifest->set_cache_key(key);
      absl::StatusOr<CatalogAsset> asset = AssetFromManifest(*manifest, options.include_quality_views);
      if (!asset.ok()) return asset.status();
      found = by_key.emplace(key, std::move(*asset)).first;
    }
    if (!found->second.baker_version.empty()) baker_versions.insert(found->second.baker_version);
    catalog.assets.emplace(name, found->second);
  }
  catalog.baker_version = absl::StrJoin(baker_versions, ",");
  report.assets = static_cast<int>(catalog.assets.size());

  // 1. Blobs: each distinct digest once.
  std::map<std::string, int64_t> blobs;
  for (const auto& [name, asset] : catalog.assets) {
    for (const CatalogFile& f : asset.files) blobs.emplace(f.sha256, f.size_bytes);
  }
  for (const auto& [hex, size] : blobs) {
    const fs::path path = options.out / BlobPath(hex);
    if (BlobIntact(path, hex, size)) {
      ++report.blobs_present;
      continue;
    }
    if (absl::Status s = MakeDirs(path.parent_path()); !s.ok()) return s;
    v1::Digest digest;
    digest.set_hash(hex);
    digest.set_size_bytes(size);
    if (absl::Status s = sdk::DownloadBlobToFile(transport, digest, path); !s.ok()) return s;
    ++report.blobs_written;
    report.bytes_written += size;
  }
  if (absl::Status s = SyncTree(options.out); !s.ok()) return s;

  // 2. The catalog: the channel's current one when it holds exactly these
  // assets (same inputs, same digest), else a new one.
  const fs::path channel_file = options.out / ChannelPath(options.channel);
  report.channel_path = ChannelPath(options.channel);
  std::optional<ChannelPointer> previous;
  std::string catalog_text;
  if (std::optional<std::string> text = ReadFile(channel_file); text.has_value()) {
    absl::StatusOr<ChannelPointer> pointer = ParseChannel(*text, channel_file.string());
    if (pointer.ok()) {
      previous = *pointer;
      std::optional<std::string> old = ReadFile(options.out / CatalogPath(pointer->catalog_sha256));
      if (old.has_value() && Sha256Hex(*old) == pointer->catalog_sha256) {
        absl::StatusOr<Catalog> parsed = ParseCatalog(*old, channel_file.string());
        if (parsed.ok() && parsed->assets == catalog.assets && parsed->baker_version == catalog.baker_version) {
          catalog_text = *old;
          report.catalog_reused = true;
        }
      }
    } else {
      SdkLog().warn("publish: replacing an unreadable channel file: {}", pointer.status().ToString());
    }
  }
  if (catalog_text.empty()) {
    absl::StatusOr<int64_t> created = options.created_at_unix.has_value() ? *options.created_at_unix : SourceDateEpoch();
    if (!created.ok()) return created.status();
    catalog.created_at = Rfc3339Utc(*created);
    catalog_text = CatalogToJson(catalog);
  }
  if (static_cast<int64_t>(catalog_text.size()) > kMaxCatalogBytes) {
    return absl::InvalidArgumentError(absl::StrCat("the catalog would take ", catalog_text.size(),
                                                   " bytes, over the limit of ", kMaxCatalogBytes,
                                                   " that readers accept: split the release into channels"));
  }
  report.catalog_sha256 = Sha256Hex(catalog_text);
  report.catalog_size_bytes = static_cast<int64_t>(catalog_text.size());
  report.catalog_path = CatalogPath(report.catalog_sha256);
  const fs::path catalog_file = options.out / report.catalog_path;
  if (!BlobIntact(catalog_file, report.catalog_sha256, report.catalog_size_bytes)) {
    if (absl::Status s = MakeDirs(catalog_file.parent_path()); !s.ok()) return s;
    if (absl::Status s = WriteFileAtomically(catalog_file, catalog_text); !s.ok()) return s;
    if (absl::Status s = SyncTree(options.out); !s.ok()) return s;
  }

  // 3. The channel file, by atomic rename: readers see the old catalog or
  // the new one, never a mix.
  ChannelPointer pointer;
  pointer.channel = options.channel;
  pointer.catalog_sha256 = report.catalog_sha256;
  pointer.catalog_size_bytes = report.catalog_size_bytes;
  if (!options.sign_key_file.empty()) {
    absl::StatusOr<CatalogSignature> signature = SignCatalog(options.sign_key_file, catalog_text);
    if (!signature.ok()) return signature.status();
    pointer.signature = *signature;
  }
  const bool same_target = previous.has_value() && previous->catalog_sha256 == pointer.catalog_sha256 &&
                           previous->signature.has_value() == pointer.signature.has_value() &&
                           (!pointer.signature.has_value() || previous->signature->key_id == pointer.signature->key_id);
  if (!same_target) {
    absl::StatusOr<int64_t> now = SourceDateEpoch();
    if (!now.ok()) return now.status();
    pointer.published_at = Rfc3339Utc(std::getenv("SOURCE_DATE_EPOCH") != nullptr ? *now : NowUnix());
    if (absl::Status s = MakeDirs(channel_file.parent_path()); !s.ok()) return s;
    if (absl::Status s = WriteFileAtomically(channel_file, ChannelToJson(pointer)); !s.ok()) return s;
    if (absl::Status s = SyncTree(options.out); !s.ok()) return s;
    report.channel_changed = true;
  }
  SdkLog().info("event=release_published channel={} catalog={} assets={} blobs_written={} blobs_present={} "
                     "bytes_written={} catalog_reused={}",
                     options.channel, report.catalog_sha256, report.assets, report.blobs_written,
                     report.blobs_present, report.bytes_written, report.catalog_reused);
  return report;
}

}  // namespace impostor::delivery
