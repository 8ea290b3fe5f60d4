// The server's words for a request (impostor.v1's field names and enum
// values) in the CLI's words: what `impostor` prints when the server refuses
// what the user typed.
#ifndef IMPOSTOR_CLIENT_CLI_FLAG_TERMS_H_
#define IMPOSTOR_CLIENT_CLI_FLAG_TERMS_H_

#include <string>
#include <string_view>

namespace impostor::cli {

// "parameters.ring_views" becomes "--ring (parameters.ring_views)" (the API
// name kept, for scripts and the docs), "PRODUCT_CARDS" becomes "cards",
// "LAYOUT_RING_TOP" "ring-top"; the rest of `message` is unchanged.
std::string InFlagTerms(std::string_view message);

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_FLAG_TERMS_H_
