// A small Prometheus registry that renders the text exposition format 0.0.4
// (https://prometheus.io/docs/instrumenting/exposition_formats/): counters,
// gauges and histograms with fixed buckets, each a family of children keyed
// by label values.
//
// Written here because Debian 12 packages no Prometheus client library
// (prometheus-cpp is not in bookworm) and the format is small: `# HELP` and
// `# TYPE` lines, then one `name{label="value"} number` line per series,
// with `\`, `"` and newline escaped in label values (and `\`, newline in
// help text).
//
// Labels must be bounded by the caller: a family holds every label-value
// combination it was ever given until Clear(). Families are created at
// start-up, before any thread uses the registry; after that every method
// may be called from any thread (each family has its own mutex).
#ifndef IMPOSTOR_SERVER_METRICS_PROMETHEUS_TEXT_H_
#define IMPOSTOR_SERVER_METRICS_PROMETHEUS_TEXT_H_

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "absl/base/thread_annotations.h"

namespace impostor::metrics {

// Label value escaped for the exposition format (without the quotes).
std::string EscapeLabelValue(std::string_view value);
// HELP text escaped for the exposition format.
std::string EscapeHelp(std::string_view help);
// A sample value as the format writes it: whole numbers without exponent or
// decimals, "+Inf", "-Inf", "NaN", else the shortest round-tripping form.
std::string FormatValue(double value);

class Family {
 public:
  enum class Type { kCounter, kGauge, kHistogram };
  Family(std::string name, std::string help, Type type, std::vector<std::string> label_names)
      : name_(std::move(name)), help_(std::move(help)), type_(type), label_names_(std::move(label_names)) {}
  virtual ~Family() = default;
  // Appends the family's HELP, TYPE and sample lines to `out`.
  virtual void Render(std::string& out) const = 0;
  const std::string& name() const { return name_; }

 protected:
  // `{a="x",b="y"}` for these values (and an extra label, e.g. le), or "".
  std::string LabelText(const std::vector<std::string>& values, std::string_view extra_name = {},
                        std::string_view extra_value = {}) const;
  void RenderHeader(std::string& out) const;

  const std::string name_;
  const std::string help_;
  const Type type_;
  const std::vector<std::string> label_names_;
};

// Counter or gauge: one number per label-value combination.
class ValueFamily final : public Family {
 public:
  using Family::Family;
  // Counters: `delta` must be >= 0 (asserted).
  void Add(const std::vector<std::string>& label_values, double delta = 1.0);
  // Gauges only.
  void Set(const std::vector<std::string>& label_values, double value);
  // Forgets every child (gauges rebuilt from a snapshot at each scrape).
  void Clear();
  // 0 for a child never touched.
  double Get(const std::vector<std::string>& label_values) const;
  // A family without labels is rendered as one series, 0 until set; after
  // this call it is left out of the exposition until Set, for a gauge that
  // means nothing on some servers (a certificate's expiry without TLS).
  void set_absent_until_set() { absent_until_set_ = true; }
  void Render(std::string& out) const override;

 private:
  bool absent_until_set_ = false;
  mutable std::mutex mu_;
  std::map<std::vector<std::string>, double> values_ ABSL_GUARDED_BY(mu_);
};

// Histogram with fixed, increasing upper bounds (the +Inf bucket is added).
class HistogramFamily final : public Family {
 public:
  HistogramFamily(std::string name, std::string help, std::vector<std::string> label_names,
                  std::vector<double> upper_bounds);
  void Observe(const std::vector<std::string>& label_values, double value);
  struct Snapshot {
    std::vector<uint64_t> cumulative;  // one per bound, then +Inf
    double sum = 0;
    uint64_t count = 0;
  };
  Snapshot Get(const std::vector<std::string>& label_values) const;
  void Render(std::string& out) const override;

 private:
  const std::vector<double> upper_bounds_;
  mutable std::mutex mu_;
  struct Child {
    std::vector<uint64_t> buckets;  // not cumulative; last = above every bound
    double sum = 0;
    uint64_t count = 0;
  };
  std::map<std::vector<std::string>, Child> children_ ABSL_GUARDED_BY(mu_);
};

// Owns families and renders them in registration order.
class Registry {
 public:
  ValueFamily& AddCounter(std::string name, std::string help, std::vector<std::string> label_names = {});
  ValueFamily& AddGauge(std::string name, std::string help, std::vector<std::string> label_names = {});
  HistogramFamily& AddHistogram(std::string name, std::string help, std::vector<std::string> label_names,
                                std::vector<double> upper_bounds);
  // The whole exposition (Content-Type: text/plain; version=0.0.4).
  std::string Render() const;

 private:
  std::vector<std::unique_ptr<Family>> families_;
};

}  // namespace impostor::metrics

#endif  // IMPOSTOR_SERVER_METRICS_PROMETHEUS_TEXT_H_
