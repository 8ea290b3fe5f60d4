// Test helper of the origin's tests (impostor-server --http-releases): a
// release tree in a temporary folder, written file by file as `impostor
// publish` would (blobs and catalogs named by their digest, channels
// replaced by a rename), and removed with everything in it when the object
// goes. One thread at a time.
#ifndef IMPOSTOR_TESTS_DELIVERY_ORIGIN_TREE_WRITER_H_
#define IMPOSTOR_TESTS_DELIVERY_ORIGIN_TREE_WRITER_H_

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include <gtest/gtest.h>

#include "common/util/sha256.h"

namespace impostor::testing {

class TempReleaseTree {
 public:
  // <tmp>/impostor_origin_<pid>_<name>/ holding tree/v1/ (the release tree)
  // and outside/ (a folder beside the tree, for links that leave it).
  explicit TempReleaseTree(const std::string& name)
      : dir_(std::filesystem::temp_directory_path() /
             ("impostor_origin_" + std::to_string(::getpid()) + "_" + name)) {
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(root() / "v1");
    std::filesystem::create_directories(outside());
  }
  ~TempReleaseTree() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  TempReleaseTree(const TempReleaseTree&) = delete;
  TempReleaseTree& operator=(const TempReleaseTree&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  std::filesystem::path root() const { return dir_ / "tree"; }
  std::filesystem::path outside() const { return dir_ / "outside"; }

  static std::string BlobPath(const std::string& hex) { return "v1/blobs/sha256/" + hex.substr(0, 2) + "/" + hex; }
  static std::string CatalogPath(const std::string& hex) {
    return "v1/catalogs/sha256/" + hex.substr(0, 2) + "/" + hex;
  }
  static std::string ChannelPath(const std::string& name) { return "v1/channels/" + name + ".json"; }

  // Writes `bytes` at `relative` under the root (folders made as needed).
  void Write(const std::string& relative, const std::string& bytes) const {
    const std::filesystem::path path = root() / relative;
    std::filesystem::create_directories(path.parent_path());
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    ASSERT_TRUE(out.good()) << "cannot write " << path;
  }
  // A blob or catalog named by its digest; returns that digest (hex).
  std::string AddBlob(const std::string& bytes) const { return AddNamed(BlobPath(Sha256Hex(bytes)), bytes); }
  std::string AddCatalog(const std::string& bytes) const { return AddNamed(CatalogPath(Sha256Hex(bytes)), bytes); }
  // Replaces the channel file by a rename, as a publish does.
  void SetChannel(const std::string& name, const std::string& bytes) const {
    const std::string relative = ChannelPath(name);
    Write(relative + ".tmp", bytes);
    std::filesystem::rename(root() / (relative + ".tmp"), root() / relative);
  }

 private:
  std::string AddNamed(const std::string& relative, const std::string& bytes) const {
    Write(relative, bytes);
    return relative.substr(relative.rfind('/') + 1);
  }

  const std::filesystem::path dir_;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_DELIVERY_ORIGIN_TREE_WRITER_H_
