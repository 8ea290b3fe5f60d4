// The Prometheus text writer (server/metrics/prometheus_text.h) and the
// tests' exposition parser, each checked against the other and against
// hand-written exposition text.
#include "server/metrics/prometheus_text.h"

#include <cmath>

#include <gtest/gtest.h>

#include "tests/metrics/exposition_parser.h"

namespace impostor {
namespace {

using metrics::EscapeHelp;
using metrics::EscapeLabelValue;
using metrics::FormatValue;
using testing::ParseExposition;

TEST(PrometheusText, EscapesLabelValues) {
  EXPECT_EQ(EscapeLabelValue("plain"), "plain");
  EXPECT_EQ(EscapeLabelValue("a\"b"), "a\\\"b");
  EXPECT_EQ(EscapeLabelValue("back\\slash"), "back\\\\slash");
  EXPECT_EQ(EscapeLabelValue("two\nlines"), "two\\nlines");
  EXPECT_EQ(EscapeHelp("say \"x\"\\\n"), "say \"x\"\\\\\\n");
}

TEST(PrometheusText, FormatsValues) {
  EXPECT_EQ(FormatValue(0), "0");
  EXPECT_EQ(FormatValue(42), "42");
  EXPECT_EQ(FormatValue(-3), "-3");
  EXPECT_EQ(FormatValue(0.25), "0.25");
  EXPECT_EQ(FormatValue(1e20), "1e+20");
  EXPECT_EQ(FormatValue(INFINITY), "+Inf");
  EXPECT_EQ(FormatValue(-INFINITY), "-Inf");
  EXPECT_EQ(FormatValue(NAN), "NaN");
  EXPECT_EQ(std::stod(FormatValue(0.1 + 0.2)), 0.1 + 0.2);  // round-trips
}

TEST(PrometheusText, RendersEveryKindAndParsesBack) {
  metrics::Registry registry;
  auto& counter = registry.AddCounter("test_events_total", "Events by kind", {"kind"});
  auto& gauge = registry.AddGauge("test_queue", "Queue length");
  auto& histogram = registry.AddHistogram("test_seconds", "Durations", {"product"}, {0.5, 1, 5});
  counter.Add({"a\"quoted\\\nname"}, 2);
  counter.Add({"plain"});
  counter.Add({"plain"}, 3);
  gauge.Set({}, 7.5);
  for (double v : {0.1, 0.5, 0.7, 3.0, 100.0}) histogram.Observe({"atlas"}, v);

  const std::string text = registry.Render();
  auto parsed = ParseExposition(text);
  ASSERT_TRUE(parsed.ok()) << parsed.status() << "\n" << text;
  EXPECT_EQ(parsed->types.at("test_events_total"), "counter");
  EXPECT_EQ(parsed->types.at("test_queue"), "gauge");
  EXPECT_EQ(parsed->types.at("test_seconds"), "histogram");
  EXPECT_EQ(parsed->Value("test_events_total", {{"kind", "a\"quoted\\\nname"}}), 2);
  EXPECT_EQ(parsed->Value("test_events_total", {{"kind", "plain"}}), 4);
  EXPECT_EQ(parsed->Value("test_queue"), 7.5);
  // le is inclusive: 0.1 and 0.5 in the first bucket.
  EXPECT_EQ(parsed->Value("test_seconds_bucket", {{"product", "atlas"}, {"le", "0.5"}}), 2);
  EXPECT_EQ(parsed->Value("test_seconds_bucket", {{"product", "atlas"}, {"le", "1"}}), 3);
  EXPECT_EQ(parsed->Value("test_seconds_bucket", {{"product", "atlas"}, {"le", "5"}}), 4);
  EXPECT_EQ(parsed->Value("test_seconds_bucket", {{"product", "atlas"}, {"le", "+Inf"}}), 5);
  EXPECT_EQ(parsed->Value("test_seconds_count", {{"product", "atlas"}}), 5);
  EXPECT_DOUBLE_EQ(parsed->Value("test_seconds_sum", {{"product", "atlas"}}), 104.3);
  EXPECT_NE(text.find("test_events_total{kind=\"a\\\"quoted\\\\\\nname\"} 2\n"), std::string::npos) << text;
}

TEST(PrometheusText, UnlabelledFamilyShowsZeroAndClearForgetsChildren) {
  metrics::Registry registry;
  auto& plain = registry.AddCounter("test_plain_total", "Never touched");
  auto& gauge = registry.AddGauge("test_workers", "Workers", {"state"});
  gauge.Set({"idle"}, 3);
  gauge.Clear();
  gauge.Set({"busy"}, 1);
  auto parsed = ParseExposition(registry.Render());
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  EXPECT_TRUE(parsed->Has("test_plain_total"));
  EXPECT_EQ(parsed->Value("test_plain_total"), 0);
  EXPECT_FALSE(parsed->Has("test_workers", {{"state", "idle"}}));
  EXPECT_EQ(parsed->Value("test_workers", {{"state", "busy"}}), 1);
  plain.Add({}, 2);
  EXPECT_EQ(plain.Get({}), 2);
}

// The parser must reject what a scraper rejects, or the tests that use it
// could not fail.
TEST(ExpositionParser, RejectsMalformedText) {
  struct Case {
    const char* name;
    const char* text;
    const char* expect;  // part of the error
  };
  const Case cases[] = {
      {"no trailing newline", "a 1", "newline"},
      {"bad metric name", "1abc 1\n", "metric name"},
      {"missing value", "a\n", "space before the value"},
      {"non-number", "a one\n", "not a number"},
      {"bad escape", "a{l=\"x\\t\"} 1\n", "invalid escape"},
      {"unterminated label", "a{l=\"x} 1\n", "unterminated"},
      {"label twice", "a{l=\"x\",l=\"y\"} 1\n", "given twice"},
      {"duplicate series", "a{l=\"x\"} 1\na{l=\"x\"} 2\n", "duplicate"},
      {"type after samples", "a 1\n# TYPE a counter\n", "TYPE after samples"},
      {"second type", "# TYPE a counter\n# TYPE a gauge\n", "second TYPE"},
      {"unknown type", "# TYPE a timer\n", "bad TYPE"},
      {"split family", "a 1\nb 1\na{x=\"1\"} 1\n", "not together"},
      {"negative counter", "# TYPE a_total counter\na_total -1\n", "negative"},
      {"histogram without +Inf", "# TYPE h histogram\nh_bucket{le=\"1\"} 1\nh_count 1\nh_sum 1\n", "+Inf"},
      {"histogram not cumulative",
       "# TYPE h histogram\nh_bucket{le=\"1\"} 2\nh_bucket{le=\"+Inf\"} 1\nh_count 1\nh_sum 1\n", "cumulative"},
      {"histogram count mismatch", "# TYPE h histogram\nh_bucket{le=\"+Inf\"} 2\nh_count 1\nh_sum 1\n", "_count"},
      {"bare histogram sample", "# TYPE h histogram\nh 1\n", "only _bucket"},
  };
  for (const Case& c : cases) {
    auto parsed = ParseExposition(c.text);
    ASSERT_FALSE(parsed.ok()) << c.name;
    EXPECT_NE(std::string(parsed.status().message()).find(c.expect), std::string::npos)
        << c.name << ": " << parsed.status();
  }
}

TEST(ExpositionParser, AcceptsValidText) {
  auto parsed = ParseExposition(
      "# plain comment\n# HELP a_total Things.\n# TYPE a_total counter\na_total{x=\"1\",} 3 1700000000000\n"
      "\n# TYPE g gauge\ng -Inf\nuntyped_thing NaN\n");
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  EXPECT_EQ(parsed->Value("a_total", {{"x", "1"}}), 3);
  EXPECT_EQ(parsed->help.at("a_total"), "Things.");
  EXPECT_TRUE(std::isinf(parsed->Value("g")));
}

}  // namespace
}  // namespace impostor
