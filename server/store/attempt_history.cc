#include "server/store/attempt_history.h"

#include <algorithm>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "common/util/utf8.h"

namespace impostor {

void OpenAttempt(v1::Job& job, const std::string& worker_id, const std::string& device, int64_t now_ms) {
  auto* history = job.mutable_attempt_history();
  if (static_cast<size_t>(history->size()) >= kMaxAttemptHistory) {
    const int drop = history->size() - static_cast<int>(kMaxAttemptHistory) + 1;
    history->DeleteSubrange(0, drop);
    job.set_attempt_history_dropped(job.attempt_history_dropped() + drop);
  }
  v1::JobAttempt* a = history->Add();
  a->set_attempt(job.attempts());
  a->set_worker_id(worker_id);
  a->set_device(device);
  a->set_leased_ms(now_ms);
  a->set_outcome(v1::JobAttempt::OUTCOME_RUNNING);
}

void CloseAttempt(v1::Job& job, v1::JobAttempt::Outcome outcome, std::string_view message, int64_t now_ms) {
  if (job.attempt_history_size() == 0) return;
  v1::JobAttempt* a = job.mutable_attempt_history(job.attempt_history_size() - 1);
  if (a->outcome() != v1::JobAttempt::OUTCOME_RUNNING) return;
  a->set_outcome(outcome);
  a->set_ended_ms(now_ms);
  // Cut on a UTF-8 boundary: a stored proto string must stay valid UTF-8.
  a->set_message(std::string(Utf8Prefix(message, kMaxAttemptMessageBytes)));
}

void CopyAttemptHistory(const v1::Job& from, v1::Job& to) {
  *to.mutable_attempt_history() = from.attempt_history();
  to.set_attempt_history_dropped(from.attempt_history_dropped());
}

std::string AttemptOutcomeName(v1::JobAttempt::Outcome outcome) {
  std::string name = v1::JobAttempt::Outcome_Name(outcome);
  if (absl::StartsWith(name, "OUTCOME_")) name = name.substr(8);
  if (name.empty()) name = "unspecified";
  return absl::AsciiStrToLower(name);
}

}  // namespace impostor
