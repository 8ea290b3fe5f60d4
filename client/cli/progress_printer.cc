#include "client/cli/progress_printer.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_format.h"
#include "common/util/log_escape.h"

namespace impostor::cli {

std::string ProgressPrinter::Format(const sdk::JobUpdate& update) {
  // Progress travels as a float: 0.42f is 0.41999998..., which must still
  // read 42%, hence the epsilon; floor so that 99.6% never shows as done.
  const int percent = static_cast<int>(std::floor(std::clamp(update.progress, 0.0, 1.0) * 100 + 1e-4));
  std::string line = absl::StrFormat("[%-7s %3d%%]", std::string(sdk::JobStateName(update.state)), percent);
  // Stages are short words, except a queued job's reason for waiting
  // ("waiting for a worker with at least 17.2 GB of host memory ...", issue
  // 44), which is the line's point: room for it, still capped.
  if (!update.stage.empty()) line += " " + EscapeForTerminal(update.stage, 256);
  return line;
}

void ProgressPrinter::Update(const sdk::JobUpdate& update) {
  if (is_tty_) {
    // \r back to column 0, then erase to the end of the line (ANSI EL).
    std::fprintf(out_, "\r%s\x1b[K", Format(update).c_str());
    line_open_ = true;
  } else {
    const std::string key = std::string(sdk::JobStateName(update.state)) + "/" + update.stage;
    if (key == last_key_) return;
    last_key_ = key;
    std::fprintf(out_, "%s\n", Format(update).c_str());
  }
  std::fflush(out_);
}

void ProgressPrinter::Finish() {
  if (line_open_) {
    std::fprintf(out_, "\n");
    std::fflush(out_);
    line_open_ = false;
  }
}

}  // namespace impostor::cli
