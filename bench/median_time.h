// The median wall time of repeated runs, for the benches that print one
// figure per case (a median shrugs off the odd run a shared machine spoils).
#ifndef IMPOSTOR_BENCH_MEDIAN_TIME_H_
#define IMPOSTOR_BENCH_MEDIAN_TIME_H_

#include <algorithm>
#include <chrono>
#include <vector>

namespace impostor::bench {

// Runs `f` `runs` times (at least once) and returns the median, in seconds.
template <typename F>
double MedianSeconds(int runs, F f) {
  std::vector<double> s;
  for (int i = 0; i < std::max(1, runs); ++i) {
    const auto t = std::chrono::steady_clock::now();
    f();
    s.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count());
  }
  std::sort(s.begin(), s.end());
  return s[s.size() / 2];
}

}  // namespace impostor::bench

#endif  // IMPOSTOR_BENCH_MEDIAN_TIME_H_
