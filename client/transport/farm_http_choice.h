// Which farm HTTP front end a transport fetches large result files from
// (client/transfer/farm_http_fetch.h): the one it was given
// (ClientOptions::farm_http or $IMPOSTOR_FARM_HTTP), else the one the farm
// advertises on its GetResult answers (impostor-server --http-advertise),
// unless "none" turned both off.
//
// Thread-safety: every method may be called from any thread.
#ifndef IMPOSTOR_CLIENT_TRANSPORT_FARM_HTTP_CHOICE_H_
#define IMPOSTOR_CLIENT_TRANSPORT_FARM_HTTP_CHOICE_H_

#include <mutex>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/strings/string_view.h"

namespace impostor::sdk {

class FarmHttpChoice {
 public:
  // `configured`: checked, "" for none given; `turned_off`: "none" was
  // given; `tls`: the transport's gRPC is TLS (only https:// is usable).
  FarmHttpChoice(std::string configured, bool turned_off, bool tls)
      : configured_(std::move(configured)), turned_off_(turned_off), tls_(tls) {}

  // The front end to use now, without a trailing "/"; "" for none.
  std::string Current() const;

  // The value of a GetResult answer's kFarmHttpMetadataKey: taken when
  // nothing was configured or turned off and it checks out
  // (AdvertisedFarmHttp); one warning per value it cannot use.
  void Learn(absl::string_view advertised);

 private:
  const std::string configured_;
  const bool turned_off_;
  const bool tls_;
  mutable std::mutex mu_;
  std::string advertised_ ABSL_GUARDED_BY(mu_);
  std::string refused_ ABSL_GUARDED_BY(mu_);  // the last value warned about
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSPORT_FARM_HTTP_CHOICE_H_
