// Conversions between the SDK's plain structs and impostor.v1 messages.
// Pure functions; thread-safe.
#ifndef IMPOSTOR_CLIENT_TRANSPORT_JOB_CONVERT_H_
#define IMPOSTOR_CLIENT_TRANSPORT_JOB_CONVERT_H_

#include <string_view>

#include "absl/status/statusor.h"
#include "impostor/client.h"
#include "impostor/v1/bake_service.pb.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

JobUpdate ToJobUpdate(const v1::Job& job);
JobState ToJobState(v1::JobState state);

// Maps BakeSettings onto BakeParameters. INVALID_ARGUMENT listing the
// accepted names for an unknown layout. Ranges are left to the server.
absl::StatusOr<v1::BakeParameters> ToBakeParameters(const BakeSettings& settings);

// Copies the settings that are not bake parameters (priority, quality gate)
// into `request`. Ranges are left to the server.
void ApplySchedulingSettings(const BakeSettings& settings, v1::SubmitBakeRequest* request);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSPORT_JOB_CONVERT_H_
