// Shows a bake's progress on a stream (stderr): on a terminal a single line
// rewritten in place ("[running  42%] render"), elsewhere (logs, pipes) one
// line per state or stage change so that logs stay readable.
//
// Not thread-safe; used from the thread that runs WatchJob.
#ifndef IMPOSTOR_CLIENT_CLI_PROGRESS_PRINTER_H_
#define IMPOSTOR_CLIENT_CLI_PROGRESS_PRINTER_H_

#include <cstdio>
#include <string>

#include "impostor/client.h"

namespace impostor::cli {

class ProgressPrinter {
 public:
  // Does not own `out`.
  ProgressPrinter(std::FILE* out, bool is_tty) : out_(out), is_tty_(is_tty) {}
  ~ProgressPrinter() { Finish(); }

  void Update(const sdk::JobUpdate& update);
  // Ends the in-place line so that later output starts on a fresh line.
  void Finish();

  // "[running  42%] render".
  static std::string Format(const sdk::JobUpdate& update);

 private:
  std::FILE* out_;
  bool is_tty_;
  bool line_open_ = false;
  std::string last_key_;  // state + stage of the last line printed (non-TTY)
};

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_PROGRESS_PRINTER_H_
