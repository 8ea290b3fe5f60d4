#include "common/request/input_paths.h"

#include <algorithm>
#include <cctype>
#include <map>
#include <vector>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

std::string FoldCase(std::string_view path) {
  std::string out(path);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

struct Placed {
  std::string field;  // "mesh.files[3].path"
  std::string path;   // as sent
};

std::string Quote(const Placed& p) { return absl::StrCat(p.field, " \"", p.path, "\""); }

}  // namespace

std::string EntryDiskPath(const v1::MeshInput& mesh) {
  const std::string& path = mesh.entry().path();
  const size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

absl::Status CheckInputPathsDisjoint(const v1::MeshInput& mesh) {
  std::vector<Placed> placed;
  placed.reserve(mesh.files_size() + 1);
  placed.push_back({"mesh.entry.path (stored as its file name)", EntryDiskPath(mesh)});
  for (int i = 0; i < mesh.files_size(); ++i) {
    placed.push_back({absl::StrCat("mesh.files[", i, "].path"), mesh.files(i).path()});
  }
  // Case-folded path -> index into `placed`.
  std::map<std::string, size_t> by_key;
  for (size_t i = 0; i < placed.size(); ++i) {
    const auto [it, inserted] = by_key.emplace(FoldCase(placed[i].path), i);
    if (inserted) continue;
    const Placed& first = placed[it->second];
    return absl::InvalidArgumentError(absl::StrCat(
        Quote(placed[i]), " and ", Quote(first),
        first.path == placed[i].path
            ? " name the same file"
            : " differ only in case and would be one file on a case-insensitive file system"));
  }
  // Every directory a path needs must not be another input's file.
  for (size_t i = 0; i < placed.size(); ++i) {
    const std::string key = FoldCase(placed[i].path);
    for (size_t slash = key.find('/'); slash != std::string::npos; slash = key.find('/', slash + 1)) {
      auto it = by_key.find(key.substr(0, slash));
      if (it == by_key.end()) continue;
      return absl::InvalidArgumentError(
          absl::StrCat(Quote(placed[i]), " needs \"", placed[i].path.substr(0, slash),
                       "\" as a directory, but ", Quote(placed[it->second]), " is a file there"));
    }
  }
  return absl::OkStatus();
}

}  // namespace impostor
