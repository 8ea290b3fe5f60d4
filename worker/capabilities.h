// What this worker tells the server it can do, with every LeaseJob (issue
// 44): its device's kind and memory, its host memory, whether its KTX2
// encoder runs, its baker version and the operator's --tags. The server
// leases it only jobs that fit (common/request/worker_fit.h).
#ifndef IMPOSTOR_WORKER_CAPABILITIES_H_
#define IMPOSTOR_WORKER_CAPABILITIES_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "impostor/v1/worker_service.pb.h"
#include "worker/gpu/atlas_renderer.h"

namespace impostor {

// Measured once, at start: host memory (or the test override,
// IMPOSTOR_WORKER_TEST_HOST_MEMORY), `basisu -version`. INVALID_ARGUMENT
// naming --tags when a tag is malformed or there are too many.
absl::StatusOr<v1::WorkerCapabilities> MeasureCapabilities(const DeviceInfo& device,
                                                           const std::vector<std::string>& tags);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_CAPABILITIES_H_
