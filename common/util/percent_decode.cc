#include "common/util/percent_decode.h"

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

absl::StatusOr<std::string> PercentDecode(std::string_view uri) {
  std::string out;
  out.reserve(uri.size());
  for (size_t i = 0; i < uri.size(); ++i) {
    char c = uri[i];
    if (c == '%') {
      if (i + 2 >= uri.size()) {
        return absl::InvalidArgumentError(absl::StrCat("truncated percent escape at byte ", i));
      }
      const int hi = HexValue(uri[i + 1]);
      const int lo = HexValue(uri[i + 2]);
      if (hi < 0 || lo < 0) return absl::InvalidArgumentError(absl::StrCat("bad percent escape at byte ", i));
      c = static_cast<char>(hi * 16 + lo);
      i += 2;
    }
    if (c == '\0') return absl::InvalidArgumentError(absl::StrCat("NUL byte in URI at byte ", i));
    out.push_back(c);
  }
  return out;
}

}  // namespace impostor
