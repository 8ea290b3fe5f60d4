// worker/bake_memory_check.h: a bake too large for the worker's memory is
// refused before anything runs, as the job's fault (RESOURCE_EXHAUSTED) or
// the worker's state (UNAVAILABLE), with a message that names the figures
// and only the advice that helps. The worker's memory is made up here;
// tests/hostile/memory_limit_test.cc sends such a job through real processes.
#include "worker/bake_memory_check.h"

#include <cstdint>
#include <string>

#include <gtest/gtest.h>

#include "absl/strings/match.h"
#include "common/request/bake_request.h"

namespace impostor {
namespace {

v1::BakeParameters Normalised(uint32_t resolution, uint32_t supersampling, uint32_t frames = 8) {
  v1::BakeParameters in;
  in.set_resolution(resolution);
  in.set_supersampling(supersampling);
  in.set_frames(frames);
  absl::StatusOr<v1::BakeParameters> p = NormalizeParameters(in);
  EXPECT_TRUE(p.ok()) << p.status();
  return p.value_or(in);
}

WorkerMemory Lavapipe(int64_t total, int64_t available, std::string bound = "cgroup memory.max") {
  return WorkerMemory{.host = HostMemory{.total_bytes = total,
                                         .available_bytes = available,
                                         .total_bound = bound,
                                         .available_bound = "MemAvailable"},
                      .device = gpu::DeviceMemoryLimits{.device_local_heap_bytes = int64_t{2} << 30,
                                                        .max_allocation_bytes = int64_t{2} << 30},
                      .device_kind = BakeDevice::kCpu,
                      .device_name = "llvmpipe (LLVM 15.0.6, 256 bits)"};
}

TEST(BakeMemoryCheck, OverTheWorkersTotalIsTheJobsFaultAndSaysSo) {
  // The red team's request on a worker in a 7.8 GB container.
  const absl::Status s = CheckBakeMemory(Normalised(16384, 1, 64), Lavapipe(7'800'000'000, 7'000'000'000));
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(std::string(s.message()),
            "an atlas of 16384 px at supersampling 1 (frames 64) needs about 17.3 GB of host memory; this worker has "
            "7.8 GB (cgroup memory.max): lower --resolution");
}

TEST(BakeMemoryCheck, AdvisesOnlyWhatWouldMakeItFit) {
  struct Case {
    const char* name;
    v1::BakeParameters parameters;
    int64_t total;
    const char* advice;
  };
  v1::BakeParameters ktx2 = Normalised(4096, 1);
  ktx2.set_texture_format(v1::TEXTURE_FORMAT_KTX2);
  const Case cases[] = {
      // 8192 px at 2: 5.4 GB of targets on lavapipe; at 1 the maps' 4.3 GB.
      {"supersampling helps", Normalised(8192, 2), 5'000'000'000, "lower --supersampling or --resolution"},
      {"only the resolution helps", Normalised(8192, 2), 1'000'000'000, "lower --resolution"},
      // KTX2 at 4096 px: 2.5 GB; PNG maps 1.1 GB.
      {"PNG maps help", ktx2, 2'000'000'000, "lower --resolution, or ask for PNG maps (--texture-format png)"},
  };
  for (const Case& c : cases) {
    const absl::Status s = CheckBakeMemory(c.parameters, Lavapipe(c.total, c.total));
    EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << c.name << ": " << s;
    EXPECT_TRUE(absl::EndsWith(s.message(), std::string(": ") + c.advice)) << c.name << ": " << s;
  }
}

TEST(BakeMemoryCheck, WithinTheTotalButNotWhatIsFreeNowIsTheWorkersState) {
  const absl::Status s = CheckBakeMemory(Normalised(4096, 2), Lavapipe(16'000'000'000, 500'000'000, "MemTotal"));
  EXPECT_EQ(s.code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(std::string(s.message()),
            "an atlas of 4096 px at supersampling 2 (frames 8) needs about 1.9 GB of host memory; this worker has "
            "16.0 GB (MemTotal) but 500 MB available now (MemAvailable): another worker may take it");
}

TEST(BakeMemoryCheck, ABakeThatFitsPasses) {
  EXPECT_TRUE(CheckBakeMemory(Normalised(2048, 2), Lavapipe(8'000'000'000, 4'000'000'000)).ok());
  // Nothing known, nothing checked.
  EXPECT_TRUE(CheckBakeMemory(Normalised(16384, 1, 64), WorkerMemory{}).ok());
}

TEST(BakeMemoryCheck, ATargetOverTheDevicesLargestAllocationIsNamed) {
  WorkerMemory gpu = Lavapipe(64'000'000'000, 64'000'000'000);
  gpu.device_kind = BakeDevice::kDedicatedGpu;
  gpu.device_name = "Tiny GPU";
  gpu.device->device_local_heap_bytes = 24'000'000'000;
  gpu.device->max_allocation_bytes = int64_t{1} << 30;
  const absl::Status s = CheckBakeMemory(Normalised(8192, 2), gpu);
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(std::string(s.message()),
            "an atlas of 8192 px at supersampling 2 (frames 8): its normal_depth render target: 2147483648 bytes "
            "(16384 px square, 8 bytes a texel) is over the device's largest allocation, 1073741824 bytes (Tiny GPU): "
            "lower --supersampling or --resolution");
}

TEST(BakeMemoryCheck, TheDevicesHeapBoundsAGpuButNotLavapipe) {
  WorkerMemory gpu = Lavapipe(64'000'000'000, 64'000'000'000);
  gpu.device_kind = BakeDevice::kDedicatedGpu;
  gpu.device_name = "Small GPU";
  gpu.device->device_local_heap_bytes = 4'000'000'000;
  gpu.device->max_allocation_bytes = int64_t{4} << 30;
  const absl::Status s = CheckBakeMemory(Normalised(8192, 2), gpu);
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(std::string(s.message()),
            "an atlas of 8192 px at supersampling 2 (frames 8) needs about 5.4 GB of device memory; this worker's "
            "Small GPU has 4.0 GB (its largest device-local heap): lower --supersampling or --resolution");
  // lavapipe's 2 GiB heap is nominal: it allocates host memory.
  EXPECT_TRUE(CheckBakeMemory(Normalised(8192, 2), Lavapipe(64'000'000'000, 64'000'000'000)).ok());
}

}  // namespace
}  // namespace impostor
