// Parses a catalog's JSON without holding every asset's document at once.
// A shipped game's catalog lists thousands of assets (11.5 MB of JSON for
// 10,000); nlohmann's DOM of all of it took about 100 MB and most of the
// parse's time in allocations, on a player's machine, at start and at every
// channel refresh. Here each member of the top-level "assets" object is
// built alone and handed on as soon as it is complete, so the peak is one
// asset's document beside the result.
//
// Internal to client/delivery (catalog.cc).
#ifndef IMPOSTOR_CLIENT_DELIVERY_ASSET_STREAM_H_
#define IMPOSTOR_CLIENT_DELIVERY_ASSET_STREAM_H_

#include <functional>
#include <string>

#include "absl/strings/string_view.h"
#include "nlohmann/json.hpp"

namespace impostor::delivery {

// As nlohmann::json::parse of `text` into `*doc`, except that each member of
// the top-level object's "assets" member, when that is an object, is not
// kept: `on_asset(name, value)` gets it as soon as its value is complete,
// in the text's order, and `*doc` keeps "assets" as an empty object. Any
// other shape (no "assets", "assets" not an object, a document that is not
// an object) parses as json::parse would. False when `text` is not JSON
// (`*doc` is then undefined); `on_asset` may have been called by then.
bool ParseWithStreamedAssets(absl::string_view text, nlohmann::json* doc,
                             const std::function<void(std::string name, nlohmann::json value)>& on_asset);

}  // namespace impostor::delivery

#endif  // IMPOSTOR_CLIENT_DELIVERY_ASSET_STREAM_H_
