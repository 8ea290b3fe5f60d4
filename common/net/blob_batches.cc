#include "common/net/blob_batches.h"

namespace impostor {

std::vector<std::vector<size_t>> PackBatchesBySize(const std::vector<int64_t>& sizes, int max_blobs,
                                                   int64_t max_bytes) {
  std::vector<std::vector<size_t>> batches;
  int64_t bytes = 0;
  for (size_t i = 0; i < sizes.size(); ++i) {
    if (batches.empty() || batches.back().size() == static_cast<size_t>(max_blobs) || bytes + sizes[i] > max_bytes) {
      batches.emplace_back();
      bytes = 0;
    }
    batches.back().push_back(i);
    bytes += sizes[i];
  }
  return batches;
}

}  // namespace impostor
