// A strict parser of the Prometheus text exposition format 0.0.4, for
// tests: it checks what a scraper relies on (metric and label name syntax,
// label value escapes, numbers, TYPE before samples and at most once, a
// family's samples together, no duplicate series, histogram buckets
// cumulative with le="+Inf" equal to _count) and gives every sample by a
// canonical key. Written for the tests because Debian's promtool comes only
// with the whole Prometheus server package.
#ifndef IMPOSTOR_TESTS_METRICS_EXPOSITION_PARSER_H_
#define IMPOSTOR_TESTS_METRICS_EXPOSITION_PARSER_H_

#include <map>
#include <string>

#include "absl/status/statusor.h"

namespace impostor::testing {

struct Exposition {
  // Canonical series key (SeriesKey) -> value.
  std::map<std::string, double> samples;
  // Family name -> "counter", "gauge", "histogram", "summary" or "untyped".
  std::map<std::string, std::string> types;
  std::map<std::string, std::string> help;

  bool Has(const std::string& name, const std::map<std::string, std::string>& labels = {}) const;
  // The sample's value; 0 when absent (a counter that never moved).
  double Value(const std::string& name, const std::map<std::string, std::string>& labels = {}) const;
  // Sum over every series of `name` whose labels include `match`.
  double Sum(const std::string& name, const std::map<std::string, std::string>& match = {}) const;
};

// `name{a="x",b="y"}` with labels sorted by name and values unescaped, or
// `name` without labels.
std::string SeriesKey(const std::string& name, const std::map<std::string, std::string>& labels);

// INVALID_ARGUMENT naming the line number and what is wrong.
absl::StatusOr<Exposition> ParseExposition(const std::string& text);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_METRICS_EXPOSITION_PARSER_H_
