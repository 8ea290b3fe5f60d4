#include "client/transport/farm_http_choice.h"

#include <string_view>
#include <utility>

#include "absl/status/statusor.h"
#include "client/base/sdk_log.h"
#include "client/transport/farm_http_url.h"
#include "common/util/log_escape.h"

namespace impostor::sdk {

std::string FarmHttpChoice::Current() const {
  if (!configured_.empty() || turned_off_) return configured_;
  std::lock_guard lock(mu_);
  return advertised_;
}

void FarmHttpChoice::Learn(absl::string_view advertised) {
  if (!configured_.empty() || turned_off_) return;
  absl::StatusOr<std::string> url = AdvertisedFarmHttp(advertised, tls_);
  std::lock_guard lock(mu_);
  if (url.ok()) {
    if (*url != advertised_) {
      SdkLog().debug("event=farm_http_advertised url={}", *url);
      advertised_ = std::move(*url);
    }
    return;
  }
  // The farm's operator can fix it; the results come over gRPC meanwhile.
  const std::string shown = EscapeUntrusted(std::string_view(advertised.data(), advertised.size()), 200);
  if (shown != refused_) {
    const absl::string_view why = url.status().message();
    SdkLog().warn("event=farm_http_advertisement_refused url=\"{}\" why=\"{}\" note=\"results come over gRPC\"", shown,
                  EscapeUntrusted(std::string_view(why.data(), why.size())));
    refused_ = shown;
  }
}

}  // namespace impostor::sdk
