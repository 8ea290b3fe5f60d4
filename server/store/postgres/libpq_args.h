// Two things every libpq call site here needs in the same shape: the
// keyword/value arrays PQconnectdbParams and PQconnectStartParams take, and
// libpq's messages on one line. Both connect paths (the pool's blocking one
// and the readiness probe's non-blocking one) and every statement use them,
// so a log line or a status reads the same whichever path failed.
#ifndef IMPOSTOR_SERVER_STORE_POSTGRES_LIBPQ_ARGS_H_
#define IMPOSTOR_SERVER_STORE_POSTGRES_LIBPQ_ARGS_H_

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace impostor {

// libpq's two null-terminated arrays over `params`, which must outlive this.
class LibpqKeywords {
 public:
  explicit LibpqKeywords(const std::vector<std::pair<std::string, std::string>>& params);
  const char* const* keywords() const { return keywords_.data(); }
  const char* const* values() const { return values_.data(); }

 private:
  std::vector<const char*> keywords_, values_;
};

// `message` (libpq's: a first line, then hints on tab-indented lines, then a
// newline) as one line: line breaks become "; ", tabs go, trailing blanks
// go.
std::string LibpqMessageLine(std::string_view message);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_POSTGRES_LIBPQ_ARGS_H_
