#include "worker/capabilities.h"

#include <algorithm>
#include <optional>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/request/bake_request.h"
#include "common/request/worker_fit.h"
#include "worker/host_memory.h"
#include "worker/output/ktx2_encoder.h"
#include "worker/test_faults.h"

namespace impostor {

absl::StatusOr<v1::WorkerCapabilities> MeasureCapabilities(const DeviceInfo& device,
                                                           const std::vector<std::string>& tags) {
  v1::WorkerCapabilities caps;
  if (static_cast<int>(tags.size()) > kMaxWorkerTags) {
    return absl::InvalidArgumentError(absl::StrCat("--tags: ", tags.size(), " tags, the limit is ", kMaxWorkerTags));
  }
  for (const std::string& tag : tags) {
    if (!IsValidWorkerTag(tag)) {
      return absl::InvalidArgumentError(absl::StrCat("--tags: \"", tag, "\" is not a tag (1..", kMaxWorkerTagBytes,
                                                     " bytes of [a-z0-9._-])"));
    }
    caps.add_tags(tag);
  }
  caps.set_device_kind(device.type.substr(0, kMaxDeviceKindBytes));
  caps.set_device_memory_bytes(std::max<int64_t>(0, device.device_local_heap_bytes));
  caps.set_max_allocation_bytes(std::max<int64_t>(0, device.max_allocation_bytes));
  std::optional<HostMemory> host = HostMemoryForTest();
  if (!host) {
    if (absl::StatusOr<HostMemory> measured = MeasureHostMemory(); measured.ok()) {
      host = *measured;
    } else {
      spdlog::warn("event=host_memory_unknown error=\"{}\" action=not_reported",
                   std::string(measured.status().message()));
    }
  }
  if (host) caps.set_host_memory_bytes(std::max<int64_t>(0, host->total_bytes));
  const absl::Status encoder = CheckBasisuVersion(DefaultBasisuPath());
  caps.set_ktx2_encoder(encoder.ok());
  if (!encoder.ok()) {
    spdlog::info("event=ktx2_encoder_missing error=\"{}\" action=no_ktx2_jobs", std::string(encoder.message()));
  }
  caps.set_baker_version(std::string(BakerVersion()));
  spdlog::info("event=capabilities device_kind={} device_memory={} max_allocation={} host_memory={} ktx2={} tags=\"{}\"",
               caps.device_kind(), caps.device_memory_bytes(), caps.max_allocation_bytes(), caps.host_memory_bytes(),
               caps.ktx2_encoder(), absl::StrJoin(caps.tags(), ","));
  return caps;
}

}  // namespace impostor
