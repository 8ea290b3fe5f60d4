// Runs independent pieces of work on several threads: the quality pass's
// views, pairs and files, each a few milliseconds, beside a bake's encoders.
#ifndef IMPOSTOR_COMMON_UTIL_PARALLEL_FOR_H_
#define IMPOSTOR_COMMON_UTIL_PARALLEL_FOR_H_

#include <algorithm>
#include <cstddef>
#include <future>
#include <thread>
#include <vector>

namespace impostor {

// Calls each(i) for every i in [0, count), on up to min(count, cores, 16)
// threads (the calling thread waits), interleaved so neighbouring indices,
// often of similar cost, land on different threads. `each` must be safe to
// call concurrently for different i. Returns when every call has returned.
template <typename F>
void ParallelFor(size_t count, F each) {
  const size_t cores = std::clamp<size_t>(std::thread::hardware_concurrency(), 1, 16);
  const size_t threads = std::min(count, cores);
  if (threads <= 1) {
    for (size_t i = 0; i < count; ++i) each(i);
    return;
  }
  std::vector<std::future<void>> jobs;
  jobs.reserve(threads);
  for (size_t worker = 0; worker < threads; ++worker) {
    jobs.push_back(std::async(std::launch::async, [&each, count, threads, worker] {
      for (size_t i = worker; i < count; i += threads) each(i);
    }));
  }
  for (auto& job : jobs) job.get();
}

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_UTIL_PARALLEL_FOR_H_
