// What a batch bake reports: one JSON object per finished asset and a final
// summary (--json, on stdout), and the live summary line for people (on
// stderr). Formatting only; BatchProgressLine is not thread-safe (the batch
// runner calls it under its own lock).
//
// JSON keys (documented in README.md and `impostor --help`):
//   {"type": "asset", "asset": path as given, "name": folder under --out,
//    "status": "succeeded" | "failed" | "skipped", "cached": bool,
//    "cache_key": hex or null, "job_id": id or null, "out_dir": DIR/<name>,
//    "files": [paths], "wall_seconds": submit to result on disk,
//    "priority": int, "quality": the manifest's quality block or null,
//    "warnings": [the manifest's warnings, as `impostor bake` prints them],
//    "error": null or "CODE: message", "error_code": 0 or a canonical code}
//   {"type": "summary", "total", "succeeded", "baked", "cached", "failed",
//    "skipped", "wall_seconds", "exit_code", "error": null or the one line
//    the command prints on stderr when it fails}
// The summary comes on every outcome, also when the batch fails before any
// asset is submitted (a bad spec: exit 2, total 0; no server: exit 3).
#ifndef IMPOSTOR_CLIENT_CLI_BATCH_REPORT_H_
#define IMPOSTOR_CLIENT_CLI_BATCH_REPORT_H_

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace impostor::cli {

enum class AssetStatus { kSucceeded, kFailed, kSkipped };

struct AssetOutcome {
  std::string asset;  // as written in SPEC / on the command line
  std::string name;
  std::string out_dir;
  AssetStatus status = AssetStatus::kFailed;
  bool cached = false;
  std::string cache_key;  // empty = not known (never submitted)
  std::string job_id;
  std::vector<std::string> files;
  double wall_seconds = 0;
  int32_t priority = 0;
  nlohmann::json quality;  // null when the manifest has no quality block
  std::vector<std::string> warnings;  // the manifest's (what the result lacks)
  int error_code = 0;      // canonical status code, 0 = none
  std::string error;       // "CODE: message", empty = none
  // The server's error reason of a refusal (RpcErrorInfo::reason, e.g.
  // "TOKEN_BAKES_PER_HOUR"), empty = none.
  std::string error_reason;
};

// Counts for the live line and the summary. held + queued + running +
// succeeded + failed + skipped <= total (the rest are not submitted yet).
struct BatchCounts {
  int total = 0;
  int held = 0;  // refused by a quota that passes; submitted again later
  int queued = 0;
  int running = 0;
  int baked = 0;   // succeeded by a new bake
  int cached = 0;  // succeeded from the cache
  int failed = 0;
  int skipped = 0;  // not submitted: the batch stopped after a failure
  int finished() const { return baked + cached + failed + skipped; }
};

nlohmann::json AssetJson(const AssetOutcome& outcome);
nlohmann::json SummaryJson(const BatchCounts& counts, double wall_seconds, int exit_code,
                           const std::string& error = "");

// "[########------------]  9/20  queued 5  running 2  done 6  cached 3  failed 0"
// (`bar_width` characters of bar; "held N" and "skipped N" appear while
// there are any).
std::string SummaryLine(const BatchCounts& counts, int bar_width = 24);

// The live summary line on a stream: on a terminal one line rewritten in
// place at most every 100 ms; elsewhere (CI logs) a new line only when the
// number of finished assets changed and at least two seconds passed, so logs
// stay short. Finish() prints the final state once.
class BatchProgressLine {
 public:
  BatchProgressLine(std::FILE* out, bool is_tty) : out_(out), is_tty_(is_tty) {}
  void Update(const BatchCounts& counts);
  void Finish(const BatchCounts& counts);
  // Prints a whole line (e.g. a failure) without garbling the live line.
  void PrintLine(const std::string& line);

 private:
  void Draw(const BatchCounts& counts);
  std::FILE* out_;
  bool is_tty_;
  bool line_open_ = false;
  bool finished_ = false;
  int last_finished_ = -1;
  std::chrono::steady_clock::time_point last_draw_{};
  std::string last_text_;
};

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_BATCH_REPORT_H_
