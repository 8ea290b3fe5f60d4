#include "worker/input_plan.h"

#include <algorithm>
#include <limits>
#include <map>
#include <string>
#include <utility>

#include "common/request/input_paths.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

constexpr int64_t kMaxBytes = std::numeric_limits<int64_t>::max();

int64_t SaturatingAdd(int64_t a, int64_t b) { return a > kMaxBytes - b ? kMaxBytes : a + b; }

// `bytes` >= 0 rounded up to whole blocks, saturating.
int64_t WholeBlocks(int64_t bytes, int64_t block_bytes) {
  const int64_t blocks = bytes / block_bytes + (bytes % block_bytes != 0 ? 1 : 0);
  return blocks > kMaxBytes / block_bytes ? kMaxBytes : blocks * block_bytes;
}

// An ext4 directory entry: 8 bytes of header and the name, 4-byte aligned.
int64_t DirentBytes(size_t name_length) { return static_cast<int64_t>((8 + name_length + 3) & ~size_t{3}); }

}  // namespace

InputPlan PlanInputs(const v1::MeshInput& mesh, const fs::path& input_dir) {
  InputPlan plan;
  plan.entry_path = input_dir / EntryDiskPath(mesh);
  std::map<std::pair<std::string, int64_t>, size_t> blob_of;  // (hash, size) -> index in plan.blobs
  auto add = [&](const v1::Digest& digest, fs::path path) {
    ++plan.path_count;
    const auto [it, is_new] = blob_of.emplace(std::make_pair(digest.hash(), digest.size_bytes()), plan.blobs.size());
    if (is_new) plan.blobs.push_back({.digest = digest, .paths = {}});
    plan.blobs[it->second].paths.push_back(std::move(path));
  };
  add(mesh.entry().digest(), plan.entry_path);
  for (const v1::InputFile& f : mesh.files()) add(f.digest(), input_dir / f.path());
  return plan;
}

ScratchDemand EstimateScratchDemand(const InputPlan& plan, const fs::path& input_dir, int64_t block_bytes) {
  ScratchDemand demand{.blob_count = static_cast<int>(plan.blobs.size()), .path_count = plan.path_count};
  std::vector<std::string> relative;
  relative.reserve(static_cast<size_t>(plan.path_count));
  for (const InputBlob& blob : plan.blobs) {
    demand.bytes = SaturatingAdd(demand.bytes, WholeBlocks(std::max<int64_t>(0, blob.digest.size_bytes()), block_bytes));
    for (const fs::path& p : blob.paths) relative.push_back(p.lexically_relative(input_dir).generic_string());
  }
  // Folders without a set of them (4096 paths of 512 one-letter folders
  // each would be two million): in sorted order, the paths under one folder
  // are neighbours, so a folder is new exactly when its closing '/' lies
  // past the part a path shares with the one before it.
  std::sort(relative.begin(), relative.end());
  int64_t folders = 1;  // input_dir
  int64_t entry_bytes = 0;
  for (size_t i = 0; i < relative.size(); ++i) {
    const std::string& path = relative[i];
    size_t shared = 0;
    if (i > 0) {
      const std::string& before = relative[i - 1];
      while (shared < path.size() && shared < before.size() && path[shared] == before[shared]) ++shared;
    }
    size_t name_start = 0;
    for (size_t k = 0; k < path.size(); ++k) {
      if (path[k] != '/') continue;
      if (k >= shared) {
        ++folders;
        entry_bytes += DirentBytes(k - name_start);
      }
      name_start = k + 1;
    }
    entry_bytes += DirentBytes(path.size() - name_start);  // the file itself
  }
  // A folder takes at least one block, and its entries fill blocks: the
  // larger of the two is a lower bound of what the folders take on ext4.
  const int64_t folder_bytes = std::max(folders * block_bytes, WholeBlocks(entry_bytes, block_bytes));
  demand.bytes = SaturatingAdd(demand.bytes, folder_bytes);
  demand.inodes = static_cast<int64_t>(plan.blobs.size()) + folders;
  return demand;
}

}  // namespace impostor
