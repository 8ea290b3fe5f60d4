// Peak resident memory of a process as Linux reports it (VmHWM), for the
// tests that bound what a hostile input may cost.
#ifndef IMPOSTOR_TESTS_HOSTILE_PEAK_RSS_H_
#define IMPOSTOR_TESTS_HOSTILE_PEAK_RSS_H_

#include <sys/types.h>
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <string>

namespace impostor::testing {

// VmHWM of process `pid` (default: this one), bytes; 0 if unreadable.
inline uint64_t PeakRss(pid_t pid = ::getpid()) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stoull(line.substr(6)) * 1024;
  }
  return 0;
}

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_HOSTILE_PEAK_RSS_H_
