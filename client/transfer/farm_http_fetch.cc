#include "client/transfer/farm_http_fetch.h"

#include "absl/strings/str_cat.h"
#include "client/base/sdk_log.h"
#include "client/transfer/blob_download.h"
#include "client/transport/farm_http_url.h"

namespace impostor::sdk {
namespace {

constexpr size_t kSinkBytes = size_t{256} << 10;

}  // namespace

HttpReadOptions FarmHttpReadOptions(const Transport& transport, const CancelSource* cancel) {
  HttpReadOptions read;
  read.stall_seconds = transport.options().rpc_timeout_seconds;
  read.max_attempts = 1;
  read.cancel = cancel;
  read.ca_file = transport.options().tls_ca_file;
  read.authorization = transport.authorization();
  return read;
}

bool UsesFarmHttp(const Transport& transport) {
  return !transport.farm_http().empty() && !transport.farm_http_record().given_up.load();
}

absl::Status ReadResultFileOverHttp(const Transport& transport, const std::string& cache_key,
                                    const std::string& file_name, const v1::Digest& digest, int64_t offset,
                                    Sha256& hash, const std::function<absl::Status(std::string_view)>& sink,
                                    const CancelSource* cancel) {
  if (transport.farm_http().empty()) {
    return absl::FailedPreconditionError("no farm HTTP front end is configured (ClientOptions.farm_http)");
  }
  Transport::FarmHttpRecord& record = transport.farm_http_record();
  if (record.given_up.load()) {
    return absl::FailedPreconditionError(absl::StrCat("the farm's HTTP front end ", transport.farm_http(),
                                                      " was given up after ", kFarmHttpFailuresToGiveUp,
                                                      " files in a row it could not give"));
  }
  // libcurl hands the body on in pieces of 16 KiB at most
  // (CURL_MAX_WRITE_SIZE): they go on to `sink` in pieces of kSinkBytes or more, so a
  // file is written in ~60 write(2) calls, not ~900. Whatever is held goes
  // on before returning, whatever the outcome: the sink has then seen every
  // byte `hash` has (the caller's resume point and its bad-bytes rule).
  std::string held;
  absl::Status sink_error;
  auto pass_on = [&]() -> absl::Status {
    if (held.empty()) return absl::OkStatus();
    absl::Status s = sink(held);
    held.clear();
    if (!s.ok()) sink_error = s;
    return s;
  };
  absl::Status read = ReadVerified(ResultFileUrl(transport.farm_http(), cache_key, file_name), digest.hash(),
                                   digest.size_bytes(), offset, hash,
                                   [&](std::string_view data) -> absl::Status {
                                     held.append(data);
                                     return held.size() >= kSinkBytes ? pass_on() : absl::OkStatus();
                                   },
                                   FarmHttpReadOptions(transport, cancel));
  if (!sink_error.ok()) return sink_error;
  if (absl::Status s = pass_on(); !s.ok()) return s;
  if (read.ok()) {
    record.failures_in_a_row.store(0);
  } else if (!absl::IsCancelled(read) && record.failures_in_a_row.fetch_add(1) + 1 >= kFarmHttpFailuresToGiveUp &&
             !record.given_up.exchange(true)) {
    SdkLog().warn("event=farm_http_given_up url={} failures_in_a_row={} last=\"{}\" note=\"every further file "
                  "of this client goes over gRPC\"",
                  transport.farm_http(), kFarmHttpFailuresToGiveUp, std::string(read.message()));
  }
  return read;
}

absl::StatusOr<std::unique_ptr<AtomicFileWriter>> DownloadResultFileToStagedFile(
    Transport& transport, const std::string& cache_key, const std::string& file_name, const v1::Digest& digest,
    const std::filesystem::path& path, const CancelSource* cancel) {
  if (UsesFarmHttp(transport)) {
    absl::StatusOr<std::unique_ptr<AtomicFileWriter>> writer = AtomicFileWriter::Create(path);
    if (!writer.ok()) return writer.status();
    bool local_error = false;  // the file's own write failed: no other road helps
    Sha256 hash;
    const absl::Status read = ReadResultFileOverHttp(
        transport, cache_key, file_name, digest, 0, hash,
        [&](std::string_view data) {
          absl::Status s = (*writer)->Append(data);
          local_error = !s.ok();
          return s;
        },
        cancel);
    if (read.ok()) {
      (*writer)->StartWriteback();
      return writer;
    }
    (*writer)->Abort();
    if (local_error || absl::IsCancelled(read)) return read;
    SdkLog().warn("event=farm_http_fallback key={} file={} reason=\"{}\" note=\"fetching it over gRPC\"", cache_key,
                  file_name, std::string(read.message()));
  }
  return DownloadBlobToStagedFile(transport, digest, path, cancel);
}

}  // namespace impostor::sdk
