// ClientOptions checked before a channel opens (Transport::Connect): each
// field's range and the server list, INVALID_ARGUMENT naming the field.
// The farm's HTTP front end and the TLS files are checked where they are
// read (farm_http_url.h, common/net/tls_channel.h).
#ifndef IMPOSTOR_CLIENT_TRANSPORT_CLIENT_OPTIONS_CHECK_H_
#define IMPOSTOR_CLIENT_TRANSPORT_CLIENT_OPTIONS_CHECK_H_

#include "absl/status/status.h"
#include "impostor/client.h"

namespace impostor::sdk {

// The largest outage budget accepted (ClientOptions::max_outage_seconds): a day.
inline constexpr double kMaxOutageSeconds = 86400;

absl::Status CheckClientOptions(const ClientOptions& o);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSPORT_CLIENT_OPTIONS_CHECK_H_
