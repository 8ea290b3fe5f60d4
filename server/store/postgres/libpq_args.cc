#include "server/store/postgres/libpq_args.h"

namespace impostor {

LibpqKeywords::LibpqKeywords(const std::vector<std::pair<std::string, std::string>>& params) {
  for (const auto& [keyword, value] : params) {
    keywords_.push_back(keyword.c_str());
    values_.push_back(value.c_str());
  }
  keywords_.push_back(nullptr);
  values_.push_back(nullptr);
}

std::string LibpqMessageLine(std::string_view message) {
  while (!message.empty() && (message.back() == '\n' || message.back() == ' ' || message.back() == '\t')) {
    message.remove_suffix(1);
  }
  std::string line;
  line.reserve(message.size());
  for (char c : message) {
    if (c == '\n') {
      line += "; ";
    } else if (c != '\t') {
      line += c;
    }
  }
  return line;
}

}  // namespace impostor
