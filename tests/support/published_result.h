// Test helper: puts a baked result into a real impostor-server without a
// GPU. It submits a bake of a tiny unique "model", leases the job through
// WorkerService like a worker would, uploads map blobs of chosen sizes (random
// bytes: the cache never decodes them) and a manifest.json, and completes
// the job. The server then serves the result under its cache key exactly as
// it would a real bake.
#ifndef IMPOSTOR_TESTS_SUPPORT_PUBLISHED_RESULT_H_
#define IMPOSTOR_TESTS_SUPPORT_PUBLISHED_RESULT_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "tests/support/server_process.h"

namespace impostor::testing {

struct PublishedResult {
  std::string key;
  // File name -> bytes, the three maps and manifest.json.
  std::map<std::string, std::string> files;
  int64_t total_bytes = 0;
};

// Maps "albedo_alpha.png", "normal_depth.png", "orm.png" with the given
// sizes. `seed` makes the bytes (and the model, hence the key) unique.
// `one_blob`: every map holds the first map's bytes (one blob under several
// names, as a LOD chain's levels can be); give equal sizes. `map_seed`
// (non-zero) makes the maps' bytes instead: two results of different seeds
// and one map_seed share their map blobs (not their manifests), as two bakes
// of one mesh that differ only in the manifest do.
PublishedResult PublishResult(ServerProcess& server, const std::vector<int64_t>& map_sizes, uint32_t seed,
                              bool one_blob = false, uint32_t map_seed = 0);

// Completes the next queued job as PublishResult does (for a job submitted
// by the caller). Returns the job's cache key.
PublishedResult CompleteNextJob(ServerProcess& server, const std::vector<int64_t>& map_sizes, uint32_t seed,
                                bool one_blob = false, uint32_t map_seed = 0);

std::string RandomBytes(int64_t size, uint32_t seed);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SUPPORT_PUBLISHED_RESULT_H_
