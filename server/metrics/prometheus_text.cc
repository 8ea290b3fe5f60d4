#include "server/metrics/prometheus_text.h"

#include <cassert>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace impostor::metrics {

std::string EscapeLabelValue(std::string_view value) {
  std::string out;
  out.reserve(value.size());
  for (char c : value) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '"') {
      out += "\\\"";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out.push_back(c);
    }
  }
  return out;
}

std::string EscapeHelp(std::string_view help) {
  std::string out;
  for (char c : help) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out.push_back(c);
    }
  }
  return out;
}

std::string FormatValue(double value) {
  if (std::isnan(value)) return "NaN";
  if (std::isinf(value)) return value > 0 ? "+Inf" : "-Inf";
  char buf[64];
  if (value == std::floor(value) && std::fabs(value) < 1e15) {
    std::snprintf(buf, sizeof buf, "%.0f", value);
    return buf;
  }
  // Shortest form that reads back as the same double.
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, value);
    if (std::strtod(buf, nullptr) == value) break;
  }
  return buf;
}

std::string Family::LabelText(const std::vector<std::string>& values, std::string_view extra_name,
                              std::string_view extra_value) const {
  if (values.empty() && extra_name.empty()) return "";
  std::string out = "{";
  for (size_t i = 0; i < values.size(); ++i) {
    if (i > 0) out += ',';
    out += label_names_[i];
    out += "=\"";
    out += EscapeLabelValue(values[i]);
    out += '"';
  }
  if (!extra_name.empty()) {
    if (!values.empty()) out += ',';
    out += extra_name;
    out += "=\"";
    out += extra_value;
    out += '"';
  }
  out += '}';
  return out;
}

void Family::RenderHeader(std::string& out) const {
  static constexpr const char* kTypeNames[] = {"counter", "gauge", "histogram"};
  out += "# HELP " + name_ + " " + EscapeHelp(help_) + "\n";
  out += "# TYPE " + name_ + " " + kTypeNames[static_cast<int>(type_)] + "\n";
}

void ValueFamily::Add(const std::vector<std::string>& label_values, double delta) {
  assert(label_values.size() == label_names_.size());
  assert(type_ != Type::kCounter || delta >= 0);
  std::lock_guard lock(mu_);
  values_[label_values] += delta;
}

void ValueFamily::Set(const std::vector<std::string>& label_values, double value) {
  assert(label_values.size() == label_names_.size());
  assert(type_ == Type::kGauge);
  std::lock_guard lock(mu_);
  values_[label_values] = value;
}

void ValueFamily::Clear() {
  std::lock_guard lock(mu_);
  values_.clear();
}

double ValueFamily::Get(const std::vector<std::string>& label_values) const {
  std::lock_guard lock(mu_);
  auto it = values_.find(label_values);
  return it == values_.end() ? 0.0 : it->second;
}

void ValueFamily::Render(std::string& out) const {
  std::lock_guard lock(mu_);
  if (absent_until_set_ && values_.empty()) return;
  RenderHeader(out);
  // A family without labels always has its one series, 0 until touched.
  if (label_names_.empty() && values_.empty()) out += name_ + " 0\n";
  for (const auto& [labels, value] : values_) out += name_ + LabelText(labels) + " " + FormatValue(value) + "\n";
}

HistogramFamily::HistogramFamily(std::string name, std::string help, std::vector<std::string> label_names,
                                 std::vector<double> upper_bounds)
    : Family(std::move(name), std::move(help), Type::kHistogram, std::move(label_names)),
      upper_bounds_(std::move(upper_bounds)) {
  for (size_t i = 1; i < upper_bounds_.size(); ++i) assert(upper_bounds_[i - 1] < upper_bounds_[i]);
}

void HistogramFamily::Observe(const std::vector<std::string>& label_values, double value) {
  assert(label_values.size() == label_names_.size());
  size_t bucket = 0;
  while (bucket < upper_bounds_.size() && value > upper_bounds_[bucket]) ++bucket;
  std::lock_guard lock(mu_);
  Child& child = children_[label_values];
  if (child.buckets.empty()) child.buckets.assign(upper_bounds_.size() + 1, 0);
  ++child.buckets[bucket];
  child.sum += value;
  ++child.count;
}

HistogramFamily::Snapshot HistogramFamily::Get(const std::vector<std::string>& label_values) const {
  Snapshot s;
  s.cumulative.assign(upper_bounds_.size() + 1, 0);
  std::lock_guard lock(mu_);
  auto it = children_.find(label_values);
  if (it == children_.end()) return s;
  uint64_t running = 0;
  for (size_t i = 0; i < it->second.buckets.size(); ++i) {
    running += it->second.buckets[i];
    s.cumulative[i] = running;
  }
  s.sum = it->second.sum;
  s.count = it->second.count;
  return s;
}

void HistogramFamily::Render(std::string& out) const {
  RenderHeader(out);
  std::lock_guard lock(mu_);
  for (const auto& [labels, child] : children_) {
    uint64_t running = 0;
    for (size_t i = 0; i <= upper_bounds_.size(); ++i) {
      running += child.buckets[i];
      const std::string le = i < upper_bounds_.size() ? FormatValue(upper_bounds_[i]) : "+Inf";
      out += name_ + "_bucket" + LabelText(labels, "le", le) + " " + FormatValue(static_cast<double>(running)) + "\n";
    }
    out += name_ + "_sum" + LabelText(labels) + " " + FormatValue(child.sum) + "\n";
    out += name_ + "_count" + LabelText(labels) + " " + FormatValue(static_cast<double>(child.count)) + "\n";
  }
}

ValueFamily& Registry::AddCounter(std::string name, std::string help, std::vector<std::string> label_names) {
  families_.push_back(
      std::make_unique<ValueFamily>(std::move(name), std::move(help), Family::Type::kCounter, std::move(label_names)));
  return static_cast<ValueFamily&>(*families_.back());
}

ValueFamily& Registry::AddGauge(std::string name, std::string help, std::vector<std::string> label_names) {
  families_.push_back(
      std::make_unique<ValueFamily>(std::move(name), std::move(help), Family::Type::kGauge, std::move(label_names)));
  return static_cast<ValueFamily&>(*families_.back());
}

HistogramFamily& Registry::AddHistogram(std::string name, std::string help, std::vector<std::string> label_names,
                                        std::vector<double> upper_bounds) {
  families_.push_back(std::make_unique<HistogramFamily>(std::move(name), std::move(help), std::move(label_names),
                                                        std::move(upper_bounds)));
  return static_cast<HistogramFamily&>(*families_.back());
}

std::string Registry::Render() const {
  std::string out;
  for (const auto& f : families_) f->Render(out);
  return out;
}

}  // namespace impostor::metrics
