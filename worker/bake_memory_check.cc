#include "worker/bake_memory_check.h"

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "worker/gpu/gpu_memory.h"

namespace impostor {
namespace {

bool Supersampled(const v1::BakeParameters& p) {
  return (p.product() == v1::PRODUCT_ATLAS || p.product() == v1::PRODUCT_LOD_CHAIN) && p.has_supersampling();
}

// The changes to the request that would make it fit, per `fits`.
template <typename Fits>
std::string Advice(const v1::BakeParameters& p, const Fits& fits) {
  if (Supersampled(p) && p.supersampling() > 1) {
    v1::BakeParameters one = p;
    one.set_supersampling(1);
    if (fits(one)) return "lower --supersampling or --resolution";
  }
  if (p.texture_format() == v1::TEXTURE_FORMAT_KTX2) {
    v1::BakeParameters png = p;
    png.set_texture_format(v1::TEXTURE_FORMAT_PNG);
    if (fits(png)) return "lower --resolution, or ask for PNG maps (--texture-format png)";
  }
  return "lower --resolution";
}

absl::Status CheckDevice(const v1::BakeParameters& p, const WorkerMemory& have) {
  const gpu::DeviceMemoryLimits& device = *have.device;
  const BakeMemoryEstimate need = EstimateBakeMemory(p, have.device_kind);
  // One allocation over the device's largest: gpu_memory.h's message.
  if (absl::Status s =
          gpu::CheckDeviceLimit(need.largest_allocation, need.largest_allocation_bytes, need.largest_allocation_shape,
                                device.max_allocation_bytes, "largest allocation", have.device_name);
      !s.ok()) {
    const auto fits = [&](const v1::BakeParameters& q) {
      return EstimateBakeMemory(q, have.device_kind).largest_allocation_bytes <= device.max_allocation_bytes;
    };
    return absl::ResourceExhaustedError(absl::StrCat(DescribeBake(p), ": its ", s.message(), ": ", Advice(p, fits)));
  }
  // A CPU device's heap is nominal (host memory bounds it, checked below).
  if (have.device_kind == BakeDevice::kCpu || device.device_local_heap_bytes <= 0) return absl::OkStatus();
  if (need.device_bytes > device.device_local_heap_bytes) {
    const auto fits = [&](const v1::BakeParameters& q) {
      return EstimateBakeMemory(q, have.device_kind).device_bytes <= device.device_local_heap_bytes;
    };
    return absl::ResourceExhaustedError(absl::StrCat(
        DescribeBake(p), " needs about ", MemoryAmount(need.device_bytes), " of device memory; this worker's ",
        have.device_name, " has ", MemoryAmount(device.device_local_heap_bytes), " (its largest device-local heap): ",
        Advice(p, fits)));
  }
  return absl::OkStatus();
}

absl::Status CheckHost(const v1::BakeParameters& p, const WorkerMemory& have) {
  const HostMemory& host = *have.host;
  const int64_t need = EstimateBakeMemory(p, have.device_kind).host_bytes;
  if (need > host.total_bytes) {
    const auto fits = [&](const v1::BakeParameters& q) {
      return EstimateBakeMemory(q, have.device_kind).host_bytes <= host.total_bytes;
    };
    return absl::ResourceExhaustedError(absl::StrCat(DescribeBake(p), " needs about ", MemoryAmount(need),
                                                     " of host memory; this worker has ", MemoryAmount(host.total_bytes),
                                                     " (", host.total_bound, "): ", Advice(p, fits)));
  }
  if (need > host.available_bytes) {
    return absl::UnavailableError(absl::StrCat(
        DescribeBake(p), " needs about ", MemoryAmount(need), " of host memory; this worker has ", MemoryAmount(host.total_bytes),
        " (", host.total_bound, ") but ", MemoryAmount(host.available_bytes), " available now (", host.available_bound,
        "): another worker may take it"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status CheckBakeMemory(const v1::BakeParameters& normalised, const WorkerMemory& have) {
  if (have.device) {
    if (absl::Status s = CheckDevice(normalised, have); !s.ok()) return s;
  }
  if (have.host) return CheckHost(normalised, have);
  return absl::OkStatus();
}

absl::Status CheckBakeFitsWorker(const v1::BakeParameters& normalised, const DeviceInfo& device,
                                 const std::optional<HostMemory>& host_override) {
  WorkerMemory have{
      .host = std::nullopt, .device = std::nullopt, .device_kind = BakeDeviceOfType(device.type), .device_name = device.name};
  if (host_override) {
    have.host = *host_override;
  } else if (absl::StatusOr<HostMemory> host = MeasureHostMemory(); host.ok()) {
    have.host = *host;
  } else {
    spdlog::warn("event=host_memory_unknown error=\"{}\" action=not_checked", std::string(host.status().message()));
  }
  have.device = gpu::DeviceMemoryLimitsOf(device);
  const BakeMemoryEstimate need = EstimateBakeMemory(normalised, have.device_kind);
  spdlog::debug("event=bake_memory_check host_need={} host_total={} host_available={} host_bound=\"{}\" "
                "device_need={} device_heap={} largest_allocation={} max_allocation={}",
                need.host_bytes, have.host ? have.host->total_bytes : -1, have.host ? have.host->available_bytes : -1,
                have.host ? have.host->total_bound : "", need.device_bytes,
                have.device ? have.device->device_local_heap_bytes : -1, need.largest_allocation_bytes,
                have.device ? have.device->max_allocation_bytes : -1);
  return CheckBakeMemory(normalised, have);
}

}  // namespace impostor
