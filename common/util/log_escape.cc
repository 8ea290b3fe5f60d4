#include "common/util/log_escape.h"

#include <cstdint>
#include <algorithm>
#include <cstdio>

namespace impostor {
namespace {

// Length of the valid UTF-8 sequence starting at text[i] (1..4), or 0.
size_t Utf8Length(std::string_view text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<uint8_t>(text[k]); };
  const uint8_t b = byte(i);
  size_t n;
  uint32_t cp;
  if (b < 0x80) return 1;
  if (b >= 0xC2 && b <= 0xDF) {
    n = 2;
    cp = b & 0x1F;
  } else if (b >= 0xE0 && b <= 0xEF) {
    n = 3;
    cp = b & 0x0F;
  } else if (b >= 0xF0 && b <= 0xF4) {
    n = 4;
    cp = b & 0x07;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  for (size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
    cp = (cp << 6) | (byte(i + k) & 0x3F);
  }
  // Overlong forms, surrogates and values past U+10FFFF are not UTF-8.
  if ((n == 3 && cp < 0x800) || (n == 4 && (cp < 0x10000 || cp > 0x10FFFF)) ||
      (cp >= 0xD800 && cp <= 0xDFFF)) {
    return 0;
  }
  // C1 controls (U+0080..U+009F): some terminals act on them.
  if (cp >= 0x80 && cp <= 0x9F) return 0;
  return n;
}

void AppendHex(std::string* out, uint8_t b) {
  char buf[5];
  std::snprintf(buf, sizeof(buf), "\\x%02X", b);
  out->append(buf);
}

std::string Escape(std::string_view text, size_t max_bytes, bool quotes) {
  std::string out;
  out.reserve(std::min(text.size(), max_bytes) + 16);
  for (size_t i = 0; i < text.size();) {
    std::string piece;
    const uint8_t b = static_cast<uint8_t>(text[i]);
    size_t consumed = 1;
    if (b == '\n') {
      piece = "\\n";
    } else if (b == '\r') {
      piece = "\\r";
    } else if (b == '\t') {
      piece = "\\t";
    } else if (quotes && (b == '\\' || b == '"')) {
      piece = {'\\', static_cast<char>(b)};
    } else if (b < 0x20 || b == 0x7F) {
      AppendHex(&piece, b);
    } else if (const size_t n = Utf8Length(text, i); n > 0) {
      piece.assign(text.substr(i, n));
      consumed = n;
    } else {
      AppendHex(&piece, b);
    }
    if (out.size() + piece.size() > max_bytes) {
      out += "...(" + std::to_string(text.size()) + " bytes)";
      return out;
    }
    out += piece;
    i += consumed;
  }
  return out;
}

}  // namespace

std::string EscapeUntrusted(std::string_view text, size_t max_bytes) {
  return Escape(text, max_bytes, /*quotes=*/true);
}

std::string EscapeForTerminal(std::string_view text, size_t max_bytes) {
  return Escape(text, max_bytes, /*quotes=*/false);
}

}  // namespace impostor
