#include "common/net/token_source.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

constexpr size_t kMaxTokenFileBytes = 4096;

std::string Trim(const std::string& s) {
  const size_t begin = s.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  return s.substr(begin, s.find_last_not_of(" \t\r\n") - begin + 1);
}

absl::StatusOr<std::string> Checked(std::string token, const std::string& source) {
  for (char c : token) {
    if (static_cast<unsigned char>(c) <= 0x20 || c == 0x7f) {
      return absl::InvalidArgumentError(
          absl::StrCat(source, ": the token contains a space or control character (one token on one line expected)"));
    }
  }
  return token;
}

}  // namespace

absl::StatusOr<std::string> ResolveToken(const std::string& token_file, const std::string& token,
                                         const char* env_token) {
  if (!token_file.empty()) {
    std::error_code ec;
    if (std::filesystem::is_directory(token_file, ec)) {
      return absl::InvalidArgumentError(absl::StrCat("--token-file: ", token_file, " is a directory, not a file"));
    }
    std::ifstream in(token_file, std::ios::binary);
    if (!in) {
      const int err = errno;
      return absl::InvalidArgumentError(absl::StrCat("--token-file: cannot read ", token_file, ": ", std::strerror(err)));
    }
    std::string text;
    text.resize(kMaxTokenFileBytes + 1);
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<size_t>(in.gcount()));
    if (text.size() > kMaxTokenFileBytes) {
      return absl::InvalidArgumentError(absl::StrCat("--token-file: ", token_file, " is over ", kMaxTokenFileBytes,
                                                     " bytes; it should hold one token"));
    }
    std::string line = Trim(text.substr(0, text.find('\n')));
    if (line.empty()) {
      return absl::InvalidArgumentError(
          Trim(text).empty() ? absl::StrCat("--token-file: ", token_file, " is empty")
                             : absl::StrCat("--token-file: ", token_file,
                                            ": its first line is empty; the token must be on the first line"));
    }
    return Checked(std::move(line), absl::StrCat("--token-file ", token_file));
  }
  if (!token.empty()) return Checked(Trim(token), "token");
  if (env_token != nullptr && env_token[0] != '\0') return Checked(Trim(env_token), kTokenEnvVar);
  return std::string();
}

}  // namespace impostor
