#include "tests/metrics/exposition_parser.h"

#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>
#include <vector>

#include "absl/strings/str_cat.h"

namespace impostor::testing {
namespace {

bool IsNameStart(char c, bool colon) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' || (colon && c == ':');
}
bool IsNameChar(char c, bool colon) { return IsNameStart(c, colon) || (c >= '0' && c <= '9'); }

bool ParseNumber(const std::string& s, double* out) {
  if (s == "+Inf" || s == "Inf") {
    *out = INFINITY;
    return true;
  }
  if (s == "-Inf") {
    *out = -INFINITY;
    return true;
  }
  if (s == "NaN") {
    *out = NAN;
    return true;
  }
  if (s.empty()) return false;
  char* end = nullptr;
  *out = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && s.find_first_of("iInN") == std::string::npos;
}

struct Sample {
  std::string name;
  std::map<std::string, std::string> labels;
  double value = 0;
};

// Parses one sample line; "" or the reason it is malformed.
std::string ParseSample(const std::string& line, Sample* out) {
  size_t i = 0;
  if (i >= line.size() || !IsNameStart(line[i], true)) return "metric name must start with [a-zA-Z_:]";
  while (i < line.size() && IsNameChar(line[i], true)) ++i;
  out->name = line.substr(0, i);
  if (i < line.size() && line[i] == '{') {
    ++i;
    while (true) {
      if (i < line.size() && line[i] == '}') {
        ++i;
        break;
      }
      const size_t start = i;
      if (i >= line.size() || !IsNameStart(line[i], false)) return "label name must start with [a-zA-Z_]";
      while (i < line.size() && IsNameChar(line[i], false)) ++i;
      const std::string label = line.substr(start, i - start);
      if (i + 1 >= line.size() || line[i] != '=' || line[i + 1] != '"') return "expected =\" after label " + label;
      i += 2;
      std::string value;
      while (true) {
        if (i >= line.size()) return "unterminated value of label " + label;
        const char c = line[i++];
        if (c == '"') break;
        if (c == '\\') {
          if (i >= line.size()) return "dangling backslash in label " + label;
          const char e = line[i++];
          if (e == 'n') {
            value += '\n';
          } else if (e == '\\' || e == '"') {
            value += e;
          } else {
            return std::string("invalid escape \\") + e + " in label " + label;
          }
        } else if (c == '\n') {
          return "raw newline in label " + label;
        } else {
          value += c;
        }
      }
      if (!out->labels.emplace(label, value).second) return "label " + label + " given twice";
      if (i < line.size() && line[i] == ',') {
        ++i;
      } else if (i < line.size() && line[i] == '}') {
        ++i;
        break;
      } else {
        return "expected , or } after the value of label " + label;
      }
    }
  }
  if (i >= line.size() || line[i] != ' ') return "expected a space before the value";
  std::istringstream rest(line.substr(i + 1));
  std::string value, timestamp, extra;
  rest >> value >> timestamp >> extra;
  if (!ParseNumber(value, &out->value)) return "value \"" + value + "\" is not a number";
  if (!extra.empty()) return "trailing text after the timestamp";
  if (!timestamp.empty()) {
    double ts = 0;
    if (!ParseNumber(timestamp, &ts) || ts != std::floor(ts)) return "timestamp is not an integer";
  }
  return "";
}

// The family a sample belongs to: a histogram's _bucket/_sum/_count map to it.
std::string FamilyOf(const std::string& name, const std::map<std::string, std::string>& types) {
  for (const char* suffix : {"_bucket", "_sum", "_count"}) {
    const std::string s = suffix;
    if (name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0) {
      const std::string base = name.substr(0, name.size() - s.size());
      auto it = types.find(base);
      if (it != types.end() && (it->second == "histogram" || (it->second == "summary" && s != "_bucket"))) return base;
    }
  }
  return name;
}

}  // namespace

std::string SeriesKey(const std::string& name, const std::map<std::string, std::string>& labels) {
  if (labels.empty()) return name;
  std::string key = name + "{";
  bool first = true;
  for (const auto& [k, v] : labels) {
    if (!first) key += ",";
    first = false;
    key += k + "=\"" + v + "\"";
  }
  return key + "}";
}

bool Exposition::Has(const std::string& name, const std::map<std::string, std::string>& labels) const {
  return samples.count(SeriesKey(name, labels)) > 0;
}

double Exposition::Value(const std::string& name, const std::map<std::string, std::string>& labels) const {
  auto it = samples.find(SeriesKey(name, labels));
  return it == samples.end() ? 0.0 : it->second;
}

double Exposition::Sum(const std::string& name, const std::map<std::string, std::string>& match) const {
  double total = 0;
  const std::string prefix = name + "{";
  for (const auto& [key, value] : samples) {
    if (key != name && key.rfind(prefix, 0) != 0) continue;
    bool ok = true;
    for (const auto& [k, v] : match) ok = ok && key.find(k + "=\"" + v + "\"") != std::string::npos;
    if (ok) total += value;
  }
  return total;
}

absl::StatusOr<Exposition> ParseExposition(const std::string& text) {
  Exposition out;
  std::set<std::string> families_done;  // families whose samples ended
  std::string current_family;
  // Histogram checks per (family, labels without le).
  struct Buckets {
    std::vector<std::pair<double, double>> les;  // (le, cumulative count)
    double count = -1;
  };
  std::map<std::string, Buckets> histograms;
  std::istringstream in(text);
  std::string line;
  int n = 0;
  if (!text.empty() && text.back() != '\n') return absl::InvalidArgumentError("the text must end with a newline");
  while (std::getline(in, line)) {
    ++n;
    auto fail = [&](const std::string& why) {
      return absl::InvalidArgumentError(absl::StrCat("line ", n, " (", line.substr(0, 120), "): ", why));
    };
    if (line.empty()) continue;
    if (line[0] == '#') {
      std::istringstream words(line.substr(1));
      std::string keyword, name;
      words >> keyword >> name;
      if (keyword != "HELP" && keyword != "TYPE") continue;  // a plain comment
      if (name.empty() || !IsNameStart(name[0], true)) return fail("bad metric name in " + keyword);
      if (keyword == "TYPE") {
        std::string type, extra;
        words >> type >> extra;
        static const std::set<std::string> kTypes = {"counter", "gauge", "histogram", "summary", "untyped"};
        if (!kTypes.count(type) || !extra.empty()) return fail("bad TYPE \"" + type + "\"");
        if (out.types.count(name)) return fail("second TYPE line for " + name);
        if (families_done.count(name) || current_family == name) return fail("TYPE after samples of " + name);
        out.types[name] = type;
      } else {
        if (out.help.count(name)) return fail("second HELP line for " + name);
        const size_t at = line.find(name) + name.size();
        out.help[name] = at < line.size() ? line.substr(at + 1) : "";
      }
      continue;
    }
    Sample s;
    if (std::string why = ParseSample(line, &s); !why.empty()) return fail(why);
    const std::string family = FamilyOf(s.name, out.types);
    if (family != current_family) {
      if (families_done.count(family)) return fail("samples of " + family + " are not together");
      if (!current_family.empty()) families_done.insert(current_family);
      current_family = family;
    }
    const auto type = out.types.find(family);
    const bool histogram = type != out.types.end() && type->second == "histogram";
    if (histogram && s.name == family) return fail("a histogram has only _bucket, _sum and _count samples");
    if (type != out.types.end() && type->second == "counter" && !(s.value >= 0)) return fail("negative counter");
    const std::string key = SeriesKey(s.name, s.labels);
    if (!out.samples.emplace(key, s.value).second) return fail("duplicate series " + key);
    if (histogram) {
      auto labels = s.labels;
      const auto le = labels.find("le");
      if (s.name == family + "_bucket") {
        if (le == labels.end()) return fail("bucket without le");
        double bound = 0;
        if (!ParseNumber(le->second, &bound)) return fail("le \"" + le->second + "\" is not a number");
        labels.erase("le");
        histograms[SeriesKey(family, labels)].les.push_back({bound, s.value});
      } else if (s.name == family + "_count") {
        histograms[SeriesKey(family, labels)].count = s.value;
      }
    }
  }
  for (auto& [series, b] : histograms) {
    auto bad = [&](const std::string& why) { return absl::InvalidArgumentError(series + ": " + why); };
    if (b.les.empty() || !std::isinf(b.les.back().first)) return bad("no le=\"+Inf\" bucket last");
    for (size_t i = 1; i < b.les.size(); ++i) {
      if (!(b.les[i].first > b.les[i - 1].first)) return bad("le bounds not increasing");
      if (b.les[i].second < b.les[i - 1].second) return bad("bucket counts not cumulative");
    }
    if (b.count != b.les.back().second) return bad("_count differs from the +Inf bucket");
  }
  return out;
}

}  // namespace impostor::testing
