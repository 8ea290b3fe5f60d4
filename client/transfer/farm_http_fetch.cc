#include "client/transfer/farm_http_fetch.h"

#include "absl/strings/str_cat.h"
#include "client/base/sdk_log.h"
#include "client/transfer/blob_download.h"
#include "client/transport/farm_http_url.h"

namespace impostor::sdk {
namespace {

constexpr size_t kSinkBytes = size_t{256} << 10;

// Counts a file the front end could not give (not a cancellation), and gives
// the front end up after kFarmHttpFailuresToGiveUp in a row; a file it gave
// resets the count.
void NoteFrontEndOutcome(const Transport& transport, const absl::Status& read) {
  Transport::FarmHttpRecord& record = transport.farm_http_record();
  if (read.ok()) {
    record.failures_in_a_row.store(0);
  } else if (!absl::IsCancelled(read) && record.failures_in_a_row.fetch_add(1) + 1 >= kFarmHttpFailuresToGiveUp &&
             !record.given_up.exchange(true)) {
    SdkLog().warn("event=farm_http_given_up url={} failures_in_a_row={} last=\"{}\" note=\"every further file "
                  "of this client goes over gRPC\"",
                  transport.farm_http(), kFarmHttpFailuresToGiveUp, std::string(read.message()));
  }
}

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

absl::Status ReadFrontEndFile(const std::string& base, const HttpReadOptions& read, const std::string& cache_key,
                             const std::string& file_name, const v1::Digest& digest, int64_t offset, Sha256& hash,
                             const std::function<absl::Status(std::string_view)>& sink) {
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
  absl::Status got = ReadVerified(ResultFileUrl(base, cache_key, file_name), digest.hash(), digest.size_bytes(),
                                  offset, hash,
                                  [&](std::string_view data) -> absl::Status {
                                    held.append(data);
                                    return held.size() >= kSinkBytes ? pass_on() : absl::OkStatus();
                                  },
                                  read);
  if (!sink_error.ok()) return sink_error;
  if (absl::Status s = pass_on(); !s.ok()) return s;
  return got;
}

absl::StatusOr<std::unique_ptr<AtomicFileWriter>> DownloadFrontEndFileToStagedFile(
    const std::string& base, const HttpReadOptions& read, const std::string& cache_key, const std::string& file_name,
    const v1::Digest& digest, const std::filesystem::path& path, bool* local_error) {
  *local_error = false;
  absl::StatusOr<std::unique_ptr<AtomicFileWriter>> writer = AtomicFileWriter::Create(path);
  if (!writer.ok()) {
    *local_error = true;
    return writer.status();
  }
  Sha256 hash;
  const absl::Status got = ReadFrontEndFile(base, read, cache_key, file_name, digest, 0, hash, [&](std::string_view data) {
    absl::Status s = (*writer)->Append(data);
    *local_error = !s.ok();
    return s;
  });
  if (!got.ok()) {
    (*writer)->Abort();
    return got;
  }
  (*writer)->StartWriteback();
  return writer;
}

absl::Status ReadResultFileOverHttp(const Transport& transport, const std::string& cache_key,
                                    const std::string& file_name, const v1::Digest& digest, int64_t offset,
                                    Sha256& hash, const std::function<absl::Status(std::string_view)>& sink,
                                    const CancelSource* cancel) {
  const std::string base = transport.farm_http();
  if (base.empty()) {
    return absl::FailedPreconditionError("no farm HTTP front end is configured (ClientOptions.farm_http)");
  }
  Transport::FarmHttpRecord& record = transport.farm_http_record();
  if (record.given_up.load()) {
    return absl::FailedPreconditionError(absl::StrCat("the farm's HTTP front end ", base, " was given up after ",
                                                      kFarmHttpFailuresToGiveUp, " files in a row it could not give"));
  }
  const absl::Status read = ReadFrontEndFile(base, FarmHttpReadOptions(transport, cancel), cache_key, file_name,
                                             digest, offset, hash, sink);
  NoteFrontEndOutcome(transport, read);
  return read;
}

absl::StatusOr<std::unique_ptr<AtomicFileWriter>> DownloadResultFileToStagedFile(
    Transport& transport, const std::string& cache_key, const std::string& file_name, const v1::Digest& digest,
    const std::filesystem::path& path, const CancelSource* cancel) {
  const std::string base = transport.farm_http();
  if (!base.empty() && !transport.farm_http_record().given_up.load()) {
    bool local_error = false;  // the file's own write failed: no other road helps
    absl::StatusOr<std::unique_ptr<AtomicFileWriter>> staged = DownloadFrontEndFileToStagedFile(
        base, FarmHttpReadOptions(transport, cancel), cache_key, file_name, digest, path, &local_error);
    if (!local_error) NoteFrontEndOutcome(transport, staged.status());
    if (staged.ok() || local_error || absl::IsCancelled(staged.status())) return staged;
    SdkLog().warn("event=farm_http_fallback key={} file={} reason=\"{}\" note=\"fetching it over gRPC\"", cache_key,
                  file_name, std::string(staged.status().message()));
  }
  return DownloadBlobToStagedFile(transport, digest, path, cancel);
}

}  // namespace impostor::sdk
