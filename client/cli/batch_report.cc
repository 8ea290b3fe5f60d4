#include "client/cli/batch_report.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace impostor::cli {
namespace {

const char* StatusName(AssetStatus s) {
  switch (s) {
    case AssetStatus::kSucceeded: return "succeeded";
    case AssetStatus::kFailed: return "failed";
    case AssetStatus::kSkipped: return "skipped";
  }
  return "failed";
}

nlohmann::json OrNull(const std::string& s) { return s.empty() ? nlohmann::json(nullptr) : nlohmann::json(s); }

}  // namespace

nlohmann::json AssetJson(const AssetOutcome& o) {
  return {
      {"type", "asset"},
      {"asset", o.asset},
      {"name", o.name},
      {"status", StatusName(o.status)},
      {"cached", o.cached},
      {"cache_key", OrNull(o.cache_key)},
      {"job_id", OrNull(o.job_id)},
      {"out_dir", o.out_dir},
      {"files", o.files},
      {"wall_seconds", o.wall_seconds},
      {"priority", o.priority},
      {"quality", o.quality.is_object() ? o.quality : nlohmann::json(nullptr)},
      {"warnings", o.warnings},
      {"error", OrNull(o.error)},
      {"error_code", o.error_code},
      {"error_reason", OrNull(o.error_reason)},
  };
}

nlohmann::json SummaryJson(const BatchCounts& c, double wall_seconds, int exit_code, const std::string& error) {
  return {
      {"type", "summary"},     {"total", c.total},     {"succeeded", c.baked + c.cached},
      {"baked", c.baked},      {"cached", c.cached},   {"failed", c.failed},
      {"skipped", c.skipped},  {"wall_seconds", wall_seconds}, {"exit_code", exit_code},
      {"error", OrNull(error)},
  };
}

std::string SummaryLine(const BatchCounts& c, int bar_width) {
  const int done = c.finished();
  const int filled = c.total > 0 ? std::min(bar_width, done * bar_width / c.total) : bar_width;
  std::string line = absl::StrCat("[", std::string(filled, '#'), std::string(bar_width - filled, '-'), "] ");
  const int digits = static_cast<int>(std::to_string(c.total).size());
  absl::StrAppend(&line, absl::StrFormat("%*d/%d", digits, done, c.total), "  queued ", c.queued, "  running ",
                  c.running, "  done ", c.baked, "  cached ", c.cached, "  failed ", c.failed);
  if (c.skipped > 0) absl::StrAppend(&line, "  skipped ", c.skipped);
  if (c.held > 0) absl::StrAppend(&line, "  held ", c.held);
  return line;
}

void BatchProgressLine::Draw(const BatchCounts& counts) {
  const std::string text = SummaryLine(counts);
  if (is_tty_) {
    std::fprintf(out_, "\r\033[K%s", text.c_str());
    line_open_ = true;
  } else {
    std::fprintf(out_, "%s\n", text.c_str());
  }
  std::fflush(out_);
  last_text_ = text;
  last_finished_ = counts.finished();
  last_draw_ = std::chrono::steady_clock::now();
}

void BatchProgressLine::Update(const BatchCounts& counts) {
  if (finished_) return;
  const auto now = std::chrono::steady_clock::now();
  if (is_tty_) {
    if (now - last_draw_ < std::chrono::milliseconds(100) || SummaryLine(counts) == last_text_) return;
  } else if (counts.finished() == last_finished_ || now - last_draw_ < std::chrono::seconds(2)) {
    return;
  }
  Draw(counts);
}

void BatchProgressLine::Finish(const BatchCounts& counts) {
  if (finished_) return;
  if (!is_tty_ || SummaryLine(counts) != last_text_ || !line_open_) Draw(counts);
  if (line_open_) std::fputs("\n", out_);
  std::fflush(out_);
  line_open_ = false;
  finished_ = true;
}

void BatchProgressLine::PrintLine(const std::string& line) {
  if (line_open_) std::fputs("\r\033[K", out_);
  std::fprintf(out_, "%s\n", line.c_str());
  if (line_open_ && !last_text_.empty()) std::fprintf(out_, "%s", last_text_.c_str());
  std::fflush(out_);
}

}  // namespace impostor::cli
