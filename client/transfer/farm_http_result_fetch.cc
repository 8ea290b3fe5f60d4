#include "client/transfer/farm_http_result_fetch.h"

#include <chrono>
#include <cstdlib>

#include <nlohmann/json.hpp>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "client/transfer/farm_http_fetch.h"
#include "client/transfer/result_fetch.h"
#include "client/transport/farm_http_url.h"
#include "client/transport/client_options_check.h"
#include "client/transport/http_get.h"
#include "common/net/farm_http_base.h"
#include "common/net/token_source.h"
#include "common/util/sha256.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

// The farm's own words for an HTTP error ({"error": {"message": ...}}), or ""
// for a body that is not its JSON (a proxy's page).
std::string ServerMessage(const std::string& body) {
  nlohmann::json parsed = nlohmann::json::parse(body, nullptr, /*allow_exceptions=*/false);
  if (!parsed.is_object() || !parsed.contains("error") || !parsed["error"].is_object()) return "";
  const nlohmann::json& message = parsed["error"].value("message", nlohmann::json());
  return message.is_string() ? message.get<std::string>() : "";
}

}  // namespace

absl::StatusOr<std::optional<FarmHttpEndpoint>> ConfiguredFarmHttp(const ClientOptions& options) {
  if (absl::Status s = CheckClientOptions(options); !s.ok()) return s;
  const bool tls = !options.tls_ca_file.empty();
  absl::StatusOr<std::string> base =
      ResolveFarmHttp(options.farm_http, "ClientOptions.farm_http", std::getenv(kFarmHttpEnvVar), tls);
  if (!base.ok()) return base.status();
  if (base->empty()) return std::nullopt;
  absl::StatusOr<std::string> token = ResolveToken(options.token_file, options.token, std::getenv(kTokenEnvVar));
  if (!token.ok()) return token.status();
  FarmHttpEndpoint front_end;
  front_end.base = std::move(*base);
  front_end.read.stall_seconds = options.rpc_timeout_seconds;
  front_end.read.max_attempts = 1;
  front_end.read.ca_file = options.tls_ca_file;
  if (!token->empty()) front_end.read.authorization = "Bearer " + *token;
  return front_end;
}

absl::StatusOr<v1::Manifest> GetResultOverHttp(const FarmHttpEndpoint& front_end, const std::string& cache_key) {
  if (!IsSha256Hex(cache_key)) {
    return absl::InvalidArgumentError(
        absl::StrCat("cache_key: expected 64 lowercase hex characters, got \"", cache_key.substr(0, 80), "\""));
  }
  const std::string url = ResultManifestUrl(front_end.base, cache_key);
  HttpGetOptions get;
  get.stall_seconds = front_end.read.stall_seconds;
  get.cancel = front_end.read.cancel;
  get.ca_file = front_end.read.ca_file;
  get.authorization = front_end.read.authorization;
  get.max_body_bytes = static_cast<int64_t>(kMaxResultManifestBytes);
  std::string body;
  absl::StatusOr<HttpGetResult> got = HttpGet(url, get, [&](std::string_view data) {
    body.append(data);
    return absl::OkStatus();
  });
  if (!got.ok()) return got.status();
  if (got->status != 200) {
    const std::string said = ServerMessage(got->error_body);
    const std::string why = absl::StrCat(url, ": HTTP ", got->status, said.empty() ? "" : ": ", said);
    return got->status == 404 ? absl::NotFoundError(why) : absl::UnavailableError(why);
  }
  if (!absl::StartsWithIgnoreCase(got->content_type, kResultManifestMediaType)) {
    return absl::DataLossError(absl::StrCat(url, ": HTTP 200 with ", got->content_type.empty() ? "no media type"
                                                                                               : got->content_type,
                                            ", not a result's listing (", kResultManifestMediaType, ")"));
  }
  // Checked whole before it is read: a body cut at a field's end would
  // parse, as a result with fewer files.
  const std::string expected = ReprDigestSha256(body);
  if (got->repr_digest.empty()) {
    return absl::DataLossError(absl::StrCat(url, ": the listing came without its ", kReprDigestHeader,
                                            " header (not the farm's answer?)"));
  }
  if (ReprDigestSha256Member(got->repr_digest) != expected) {
    return absl::DataLossError(absl::StrCat(url, ": the listing's ", body.size(), " bytes hash to ", expected,
                                            ", not to its ", kReprDigestHeader, " \"", got->repr_digest.substr(0, 200),
                                            "\": cut or altered on the way"));
  }
  v1::Manifest manifest;
  if (!manifest.ParseFromString(body)) {
    return absl::DataLossError(absl::StrCat(url, ": ", body.size(), " bytes that are not an impostor.v1.Manifest"));
  }
  if (manifest.cache_key() != cache_key) {
    return absl::DataLossError(absl::StrCat(url, ": the listing is of result \"", manifest.cache_key().substr(0, 80),
                                            "\", not of the one asked for"));
  }
  if (absl::Status s = CheckManifestFiles(manifest); !s.ok()) {
    return absl::DataLossError(absl::StrCat(url, ": ", s.message()));
  }
  return manifest;
}

absl::StatusOr<FetchResult> FetchResultFilesOverHttp(const FarmHttpEndpoint& front_end, const std::string& cache_key,
                                                     const fs::path& out_dir, int parallel) {
  const auto start = std::chrono::steady_clock::now();
  absl::StatusOr<v1::Manifest> manifest = GetResultOverHttp(front_end, cache_key);
  if (!manifest.ok()) return manifest.status();
  // Every file on its own request: with `parallel` threads, each keeping
  // its connection (http_get.h), a result's 36 small view images cost a
  // few requests per connection, as they cost curl.
  ResultFileRoads roads;
  roads.stream = [&](const std::string& file_name, const v1::Digest& digest, const fs::path& path,
                     const CancelSource& cancel) {
    HttpReadOptions read = front_end.read;
    read.cancel = &cancel;
    bool local_error = false;
    return DownloadFrontEndFileToStagedFile(front_end.base, read, cache_key, file_name, digest, path, &local_error);
  };
  absl::StatusOr<FetchResult> result = InstallResultFiles(*manifest, out_dir, parallel, roads);
  if (result.ok()) result->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace impostor::sdk
