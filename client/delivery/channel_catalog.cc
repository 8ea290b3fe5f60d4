#include "client/delivery/channel_catalog.h"

#include "absl/strings/string_view.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/base/atomic_file.h"
#include "client/base/small_file.h"
#include "client/transport/http_get.h"
#include "client/transfer/http_blob_read.h"
#include "client/delivery/release_paths.h"
#include "client/base/sdk_log.h"
#include "common/util/sha256.h"

namespace impostor::delivery {
namespace {

namespace fs = std::filesystem;
using sdk::HttpGet;
using sdk::HttpGetOptions;
using sdk::HttpGetResult;
using sdk::HttpReadOptions;
using sdk::ReadVerifiedToString;

// A channel file is a few hundred bytes; anything far larger is not one.
constexpr int64_t kMaxChannelFileBytes = 64 * 1024;

// What was kept on disk; nullopt when absent or unreadable (the channel is
// then fetched as on a first start).
std::optional<std::string> ReadKept(const fs::path& path, int64_t max_bytes) {
  absl::StatusOr<std::string> text = sdk::ReadSmallFile(path, max_bytes);
  if (!text.ok()) return std::nullopt;
  return std::move(*text);
}

absl::Status WriteAtomically(const fs::path& path, std::string_view text) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  absl::StatusOr<std::unique_ptr<sdk::AtomicFileWriter>> writer = sdk::AtomicFileWriter::Create(path);
  if (!writer.ok()) return writer.status();
  if (absl::Status s = (*writer)->Append(text); !s.ok()) return s;
  return (*writer)->Commit();
}

}  // namespace

ChannelCatalog::ChannelCatalog(ChannelCatalogOptions options) : options_(std::move(options)) {}

absl::StatusOr<std::unique_ptr<ChannelCatalog>> ChannelCatalog::Open(ChannelCatalogOptions options) {
  if (absl::Status s = ValidateChannelName(options.channel); !s.ok()) return s;
  for (const std::string& m : options.mirrors) {
    if (!absl::StartsWith(m, "http://") && !absl::StartsWith(m, "https://")) {
      return absl::InvalidArgumentError(
          absl::StrCat("mirror \"", m.substr(0, 80), "\": expected an http:// or https:// base URL"));
    }
  }
  auto catalog = std::unique_ptr<ChannelCatalog>(new ChannelCatalog(std::move(options)));
  {
    std::lock_guard lock(catalog->mu_);
    catalog->LoadFromDisk();
  }
  return catalog;
}

void ChannelCatalog::LoadFromDisk() {
  const fs::path channel_file = options_.state_dir / "channels" / (options_.channel + ".json");
  std::optional<std::string> channel_text = ReadKept(channel_file, kMaxChannelFileBytes);
  if (!channel_text.has_value()) return;
  absl::StatusOr<ChannelPointer> pointer = ParseChannel(*channel_text, channel_file.string());
  if (!pointer.ok()) {
    SdkLog().warn("release: ignoring the channel file kept on disk: {}", pointer.status().ToString());
    return;
  }
  const fs::path catalog_file = options_.state_dir / "catalogs" / pointer->catalog_sha256;
  std::optional<std::string> catalog_text = ReadKept(catalog_file, kMaxCatalogBytes);
  if (!catalog_text.has_value()) return;
  absl::StatusOr<std::shared_ptr<const Catalog>> catalog = CheckCatalog(*pointer, *catalog_text, catalog_file.string());
  if (!catalog.ok()) {
    SdkLog().warn("release: ignoring the catalog kept on disk: {}", catalog.status().ToString());
    return;
  }
  current_ = *catalog;
  current_sha256_ = pointer->catalog_sha256;
}

void ChannelCatalog::SaveToDisk(const Fetched& fetched) {
  // The catalog first: the channel file on disk always names a catalog
  // that is there.
  absl::Status s = WriteAtomically(options_.state_dir / "catalogs" / fetched.pointer.catalog_sha256,
                                   fetched.catalog_text);
  if (s.ok()) s = WriteAtomically(options_.state_dir / "channels" / (options_.channel + ".json"), fetched.channel_text);
  // Not fatal: the game goes on with the catalog in memory; only offline
  // starts lose it.
  if (!s.ok()) SdkLog().warn("release: cannot keep channel {} on disk: {}", options_.channel, s.ToString());
}

absl::StatusOr<std::shared_ptr<const Catalog>> ChannelCatalog::CheckCatalog(const ChannelPointer& pointer,
                                                                            const std::string& text,
                                                                            const std::string& source,
                                                                            bool digest_checked) const {
  if (static_cast<int64_t>(text.size()) != pointer.catalog_size_bytes ||
      (!digest_checked && Sha256Hex(text) != pointer.catalog_sha256)) {
    return absl::DataLossError(absl::StrCat(source, ": does not match catalog ", pointer.catalog_sha256));
  }
  if (options_.public_key.has_value()) {
    if (absl::Status s = VerifyCatalog(*options_.public_key, pointer.signature, text, source); !s.ok()) return s;
  }
  absl::StatusOr<Catalog> catalog = ParseCatalog(text, source);
  if (!catalog.ok()) return catalog.status();
  return std::make_shared<const Catalog>(std::move(*catalog));
}

absl::StatusOr<std::optional<ChannelCatalog::Fetched>> ChannelCatalog::FetchFrom(const std::string& mirror,
                                                                                 const std::string& etag) {
  const std::string url = JoinUrl(mirror, ChannelPath(options_.channel));
  HttpGetOptions get;
  get.stall_seconds = options_.stall_seconds;
  get.if_none_match = etag;
  get.max_body_bytes = kMaxChannelFileBytes;
  get.cancel = options_.cancel;
  get.ca_file = options_.ca_file;
  std::string body;
  absl::StatusOr<HttpGetResult> got = HttpGet(url, get, [&](std::string_view data) {
    body.append(data);
    return absl::OkStatus();
  });
  if (!got.ok()) return got.status();
  if (got->status == 304) return std::nullopt;
  if (got->status == 404) return absl::NotFoundError(absl::StrCat(url, ": HTTP 404 (no such channel)"));
  if (got->status != 200) return absl::UnavailableError(absl::StrCat(url, ": HTTP ", got->status));
  absl::StatusOr<ChannelPointer> pointer = ParseChannel(body, url);
  if (!pointer.ok()) return pointer.status();
  if (pointer->channel != options_.channel) {
    return absl::DataLossError(absl::StrCat(url, ": names channel \"", pointer->channel, "\""));
  }
  Fetched fetched;
  fetched.channel_text = std::move(body);
  fetched.pointer = std::move(*pointer);
  fetched.etag = got->etag;
  if (fetched.pointer.catalog_sha256 == current_sha256_ && current_ != nullptr) {
    fetched.catalog = current_;
    return fetched;
  }
  // The catalog from this mirror, else from the others: its name is its
  // digest, so any mirror's copy will do.
  std::vector<std::string> order{mirror};
  for (const std::string& m : options_.mirrors) {
    if (m != mirror) order.push_back(m);
  }
  std::vector<std::string> failures;
  for (const std::string& m : order) {
    const std::string catalog_url = JoinUrl(m, CatalogPath(fetched.pointer.catalog_sha256));
    HttpReadOptions read;
    read.stall_seconds = options_.stall_seconds;
    read.max_attempts = options_.max_attempts;
    read.cancel = options_.cancel;
    read.ca_file = options_.ca_file;
    absl::StatusOr<std::string> text =
        ReadVerifiedToString(catalog_url, fetched.pointer.catalog_sha256, fetched.pointer.catalog_size_bytes, read);
    if (!text.ok()) {
      if (absl::IsCancelled(text.status())) return text.status();
      failures.push_back(std::string(text.status().message()));
      continue;
    }
    absl::StatusOr<std::shared_ptr<const Catalog>> catalog =
        CheckCatalog(fetched.pointer, *text, catalog_url, /*digest_checked=*/true);
    if (!catalog.ok()) {
      if (absl::IsPermissionDenied(catalog.status())) return catalog.status();
      failures.push_back(std::string(catalog.status().message()));
      continue;
    }
    fetched.catalog_text = std::move(*text);
    fetched.catalog = *catalog;
    return fetched;
  }
  return absl::UnavailableError(absl::StrCat("catalog ", fetched.pointer.catalog_sha256, " of channel ",
                                             options_.channel, ": ", absl::StrJoin(failures, "; ")));
}

absl::StatusOr<ResolvedCatalog> ChannelCatalog::Current(bool force_refresh) {
  std::lock_guard lock(mu_);
  const auto now = std::chrono::steady_clock::now();
  if (!force_refresh && current_ != nullptr && checked_at_.has_value() &&
      now - *checked_at_ < std::chrono::duration<double>(options_.refresh_seconds)) {
    return ResolvedCatalog{current_, current_sha256_, offline_};
  }
  std::vector<std::string> failures;
  absl::Status denied;
  int not_found = 0;
  for (const std::string& mirror : options_.mirrors) {
    absl::StatusOr<std::optional<Fetched>> fetched = FetchFrom(mirror, current_ != nullptr ? etags_[mirror] : "");
    if (!fetched.ok()) {
      if (absl::IsCancelled(fetched.status())) return fetched.status();
      if (absl::IsPermissionDenied(fetched.status())) denied = fetched.status();
      if (absl::IsNotFound(fetched.status())) ++not_found;
      failures.push_back(std::string(fetched.status().message()));
      continue;
    }
    checked_at_ = now;
    warned_offline_ = false;
    offline_ = false;
    if (!fetched->has_value()) return ResolvedCatalog{current_, current_sha256_, false};  // 304
    Fetched& f = **fetched;
    etags_[mirror] = f.etag;
    if (f.pointer.catalog_sha256 != current_sha256_) {
      SaveToDisk(f);
      SdkLog().info("event=release_catalog channel={} catalog={} assets={} mirror={}", options_.channel,
                         f.pointer.catalog_sha256, f.catalog->assets.size(), mirror);
      current_ = f.catalog;
      current_sha256_ = f.pointer.catalog_sha256;
    }
    return ResolvedCatalog{current_, current_sha256_, false};
  }
  const std::string why = options_.mirrors.empty() ? std::string("no mirror is configured")
                                                   : absl::StrJoin(failures, "; ");
  if (current_ != nullptr) {
    // Asked again only after refresh_seconds: with a mirror that stalls,
    // every Get would otherwise wait out its stall first.
    checked_at_ = now;
    offline_ = true;
    if (!warned_offline_) {
      SdkLog().warn("event=release_offline channel={} catalog={} reason=\"{}\"", options_.channel,
                         current_sha256_, why);
      warned_offline_ = true;
    }
    return ResolvedCatalog{current_, current_sha256_, true};
  }
  if (!denied.ok()) return denied;
  if (not_found > 0 && not_found == static_cast<int>(options_.mirrors.size())) {
    return absl::NotFoundError(absl::StrCat("channel ", options_.channel, ": ", why));
  }
  return absl::UnavailableError(
      absl::StrCat("channel ", options_.channel, ": no mirror answered and no catalog is kept on disk: ", why));
}

}  // namespace impostor::delivery
