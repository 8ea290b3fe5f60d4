#include "client/cache/cache_options.h"

#include <cmath>
#include <string>
#include <string_view>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "client/delivery/catalog_signature.h"
#include "client/delivery/release_paths.h"
#include "client/transport/farm_http_url.h"
#include "common/net/keepalive.h"
#include "common/net/server_list.h"
#include "common/net/tls_files.h"

namespace impostor::sdk {

absl::Status ValidateOptions(const CacheOptions& o) {
  auto bad = [](std::string_view field, auto value, std::string_view range) {
    return absl::InvalidArgumentError(absl::StrCat("CacheOptions.", std::string(field), ": must be ",
                                                   std::string(range), ", got ", value));
  };
  if (o.server.empty()) {
    if (o.mirrors.empty()) return absl::InvalidArgumentError("CacheOptions.server: required unless mirrors are given");
  } else if (auto targets = ParseServerList(o.server, "CacheOptions.server"); !targets.ok()) {
    return targets.status();
  }
  for (size_t i = 0; i < o.mirrors.size(); ++i) {
    const std::string& m = o.mirrors[i];
    if ((!absl::StartsWith(m, "http://") && !absl::StartsWith(m, "https://")) || m.size() > 2048) {
      return absl::InvalidArgumentError(absl::StrCat("CacheOptions.mirrors[", i, "]: \"", m.substr(0, 80),
                                                     "\" is not an http:// or https:// base URL"));
    }
  }
  if (!o.mirrors.empty() && o.channel.empty()) {
    return absl::InvalidArgumentError("CacheOptions.channel: required with mirrors (the release channel to read)");
  }
  if (!o.channel.empty()) {
    if (o.mirrors.empty()) return absl::InvalidArgumentError("CacheOptions.channel: needs CacheOptions.mirrors");
    if (auto s = delivery::ValidateChannelName(o.channel, "CacheOptions.channel"); !s.ok()) return s;
  }
  if (!(o.catalog_refresh_seconds >= 0 && o.catalog_refresh_seconds <= 86400)) {
    return bad("catalog_refresh_seconds", o.catalog_refresh_seconds, "in 0..86400");
  }
  if (!o.catalog_public_key_file.empty()) {
    if (auto key = delivery::LoadCatalogPublicKey(o.catalog_public_key_file); !key.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("CacheOptions.catalog_public_key_file: ", key.status().message()));
    }
  }
  if (o.dir.empty()) return absl::InvalidArgumentError("CacheOptions.dir: required");
  if (o.max_bytes < 0) return bad("max_bytes", o.max_bytes, ">= 0");
  if (o.max_parallel_downloads < 1 || o.max_parallel_downloads > 64) {
    return bad("max_parallel_downloads", o.max_parallel_downloads, "in 1..64");
  }
  if (o.max_parallel_prefetches < 1 || o.max_parallel_prefetches > o.max_parallel_downloads) {
    return bad("max_parallel_prefetches", o.max_parallel_prefetches, "in 1..max_parallel_downloads");
  }
  if (o.io_threads < 1 || o.io_threads > 64) return bad("io_threads", o.io_threads, "in 1..64");
  if (!(o.rpc_timeout_seconds > 0) || std::isinf(o.rpc_timeout_seconds)) {
    return bad("rpc_timeout_seconds", o.rpc_timeout_seconds, "> 0");
  }
  if (o.max_attempts < 1) return bad("max_attempts", o.max_attempts, ">= 1");
  if (!(o.max_outage_seconds >= 0 && o.max_outage_seconds <= 86400)) {
    return bad("max_outage_seconds", o.max_outage_seconds, "in 0..86400");
  }
  if (!(o.connect_timeout_seconds > 0) || std::isinf(o.connect_timeout_seconds)) {
    return bad("connect_timeout_seconds", o.connect_timeout_seconds, "> 0");
  }
  if (auto s = ValidateKeepaliveSeconds("CacheOptions.keepalive_seconds", o.keepalive_seconds); !s.ok()) return s;
  if (!(o.offline_retry_seconds >= 0)) return bad("offline_retry_seconds", o.offline_retry_seconds, ">= 0");
  if (!(o.partial_max_age_seconds >= 0)) return bad("partial_max_age_seconds", o.partial_max_age_seconds, ">= 0");
  // TLS files are checked at Open, not at the first miss: a cache that
  // could never connect should say so at once.
  if (o.tls_ca_file.empty() && !o.tls_server_name.empty()) {
    return absl::InvalidArgumentError("CacheOptions.tls_server_name: needs CacheOptions.tls_ca_file");
  }
  if (!o.tls_ca_file.empty() || !o.tls_cert_file.empty() || !o.tls_key_file.empty()) {
    absl::StatusOr<ClientTlsPem> tls = ReadClientTlsFiles(
        {.ca = o.tls_ca_file, .cert = o.tls_cert_file, .key = o.tls_key_file},
        {.ca = "CacheOptions.tls_ca_file", .cert = "CacheOptions.tls_cert_file", .key = "CacheOptions.tls_key_file"});
    if (!tls.ok()) return tls.status();
  }
  // $IMPOSTOR_FARM_HTTP is the transport's to read, at the first miss.
  if (auto farm_http = ResolveFarmHttp(o.farm_http, "CacheOptions.farm_http", nullptr, !o.tls_ca_file.empty());
      !farm_http.ok()) {
    return farm_http.status();
  }
  return absl::OkStatus();
}

ClientOptions TransportOptions(const CacheOptions& o) {
  ClientOptions c;
  c.server = o.server;
  c.rpc_timeout_seconds = o.rpc_timeout_seconds;
  c.max_attempts = o.max_attempts;
  c.max_outage_seconds = o.max_outage_seconds;
  c.on_connection_change = o.on_connection_change;
  c.connect_timeout_seconds = o.connect_timeout_seconds;
  c.keepalive_seconds = o.keepalive_seconds;
  c.tls_ca_file = o.tls_ca_file;
  c.tls_cert_file = o.tls_cert_file;
  c.tls_key_file = o.tls_key_file;
  c.tls_server_name = o.tls_server_name;
  c.token_file = o.token_file;
  c.token = o.token;
  c.farm_http = o.farm_http;
  return c;
}

std::optional<FarmHttpEndpoint> FarmHttpOf(const CacheOptions& options) {
  if (options.server.empty()) return std::nullopt;
  absl::StatusOr<std::optional<FarmHttpEndpoint>> front_end = ConfiguredFarmHttp(TransportOptions(options));
  return front_end.ok() ? *front_end : std::nullopt;
}

}  // namespace impostor::sdk
