// The bake encodes its maps on worker threads while the quality pass
// renders (worker/bake/atlas_bake.cc). The overlap must not change a byte:
// the same bake with AtlasBakeRequest::serial_encode (encode first, then the
// quality pass) writes identical files, digests and manifest map lists. Each
// map is handed to the worker's early upload once, final.
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/request/bake_request.h"
#include "common/util/sha256.h"
#include "tests/gpu/shared_renderer_test.h"
#include "worker/bake/atlas_bake.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

const fs::path kHelmet =
    fs::path(IMPOSTOR_TEST_ASSETS_DIR) / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";

fs::path ScratchDir(const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_overlap_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string ReadAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

class EncodeOverlapTest : public testing::SharedRendererTest {
 protected:
  static absl::StatusOr<AtlasBakeOutput> Bake(
      const v1::BakeParameters& in, const fs::path& dir, bool serial,
      std::function<void(const fs::path&, const BlobDigest&)> map_written = nullptr) {
    auto p = NormalizeParameters(in);
    if (!p.ok()) return p.status();
    const std::atomic<bool> cancelled{false};
    AtlasBakeRequest request{.entry_file = kHelmet,
                             .parameters = *p,
                             .cache_key = "overlap-test",
                             .output_dir = dir,
                             .load_limits = {},
                             .serial_encode = serial,
                             .map_written = std::move(map_written)};
    return BakeAtlas(request, *renderer_, [](std::string_view, double) {}, cancelled);
  }

  static v1::BakeParameters Params() {
    v1::BakeParameters params;
    params.set_layout(v1::LAYOUT_OCTAHEDRAL);
    params.set_frames(4);
    params.set_resolution(256);
    params.set_supersampling(2);
    params.set_emissive(true);
    params.set_quality_views(4);  // the pass the encoding overlaps
    return params;
  }
};

TEST_F(EncodeOverlapTest, OverlappedEncodingWritesTheSameBytesAsSerial) {
  if (!fs::exists(kHelmet)) GTEST_SKIP() << "asset missing: " << kHelmet;
  const fs::path serial_dir = ScratchDir("serial"), overlap_dir = ScratchDir("overlap");
  auto serial = Bake(Params(), serial_dir, /*serial=*/true);
  ASSERT_TRUE(serial.ok()) << serial.status();
  auto overlap = Bake(Params(), overlap_dir, /*serial=*/false);
  ASSERT_TRUE(overlap.ok()) << overlap.status();

  // The manifest lists the same maps, in the same order, with the same
  // digests: the encoded maps, the contact sheet, then the quality views.
  ASSERT_EQ(overlap->manifest.maps_size(), serial->manifest.maps_size());
  for (int i = 0; i < serial->manifest.maps_size(); ++i) {
    const v1::MapFile& a = serial->manifest.maps(i);
    const v1::MapFile& b = overlap->manifest.maps(i);
    EXPECT_EQ(b.semantic(), a.semantic()) << i;
    EXPECT_EQ(b.file(), a.file()) << i;
    EXPECT_EQ(b.digest().hash(), a.digest().hash()) << a.file();
    EXPECT_EQ(b.digest().size_bytes(), a.digest().size_bytes()) << a.file();
    EXPECT_EQ(b.width(), a.width()) << a.file();
  }
  std::map<std::string, int> kinds;
  for (const v1::MapFile& m : serial->manifest.maps()) ++kinds[m.semantic()];
  for (const char* s : {"albedo_alpha", "normal_depth", "orm", "emissive", "contact_sheet"}) {
    EXPECT_EQ(kinds[s], 1) << s;
  }
  EXPECT_EQ(serial->manifest.maps(serial->manifest.maps_size() - 1).semantic().rfind("contact_sheet", 0),
            std::string::npos)
      << "the quality pass's files come after the contact sheet";
  EXPECT_EQ(overlap->manifest.quality().silhouette_iou_mean(), serial->manifest.quality().silhouette_iou_mean());
  EXPECT_GT(serial->manifest.quality().silhouette_iou_mean(), 0.5f);

  // Every file but the manifest (it carries timings) is byte-identical.
  int files = 0;
  for (const auto& entry : fs::directory_iterator(serial_dir)) {
    const std::string name = entry.path().filename().string();
    if (name == "manifest.json") continue;
    ASSERT_TRUE(fs::exists(overlap_dir / name)) << name;
    EXPECT_EQ(ReadAll(overlap_dir / name), ReadAll(entry.path())) << name;
    ++files;
  }
  EXPECT_EQ(files, static_cast<int>(std::distance(fs::directory_iterator(overlap_dir), fs::directory_iterator())) - 1);
  EXPECT_GE(files, 6);
  fs::remove_all(serial_dir);
  fs::remove_all(overlap_dir);
}

// The worker uploads each map as soon as the bake hands it over
// (AtlasBakeRequest::map_written, worker/early_result_upload.h): every
// encoded map exactly once, with the digest the manifest then records and
// the bytes the file finally holds, also when --array rewrites the maps as
// strips after the atlases were written.
TEST_F(EncodeOverlapTest, EachMapIsHandedOverOnceWithItsFinalDigest) {
  if (!fs::exists(kHelmet)) GTEST_SKIP() << "asset missing: " << kHelmet;
  for (const bool array : {false, true}) {
    SCOPED_TRACE(array ? "--array" : "atlas");
    const fs::path dir = ScratchDir(array ? "handed_array" : "handed");
    std::mutex mu;
    std::map<std::string, std::vector<BlobDigest>> handed;
    v1::BakeParameters params = Params();
    params.set_texture_array(array);
    auto out = Bake(params, dir, /*serial=*/false, [&](const fs::path& file, const BlobDigest& digest) {
      std::lock_guard lock(mu);
      handed[file.filename().string()].push_back(digest);
    });
    ASSERT_TRUE(out.ok()) << out.status();
    int maps = 0;
    for (const v1::MapFile& m : out->manifest.maps()) {
      const bool encoded_map = m.semantic() == "albedo_alpha" || m.semantic() == "normal_depth" ||
                               m.semantic() == "orm" || m.semantic() == "emissive";
      if (!encoded_map) {
        EXPECT_FALSE(handed.contains(m.file())) << m.file() << " is not a map the bake hands over";
        continue;
      }
      ++maps;
      ASSERT_EQ(handed[m.file()].size(), 1u) << m.file();
      const BlobDigest& d = handed[m.file()].front();
      EXPECT_EQ(d.hash, m.digest().hash()) << m.file();
      EXPECT_EQ(d.size_bytes, m.digest().size_bytes()) << m.file();
      auto on_disk = DigestFile(dir / m.file());
      ASSERT_TRUE(on_disk.ok()) << on_disk.status();
      EXPECT_EQ(*on_disk, d) << m.file() << " changed after it was handed over";
    }
    EXPECT_EQ(maps, 4) << "albedo_alpha, normal_depth, orm, emissive";
    EXPECT_EQ(handed.size(), 4u);
    fs::remove_all(dir);
  }
}

TEST_F(EncodeOverlapTest, AnOutputDirThatCannotBeWrittenFailsCleanly) {
  if (!fs::exists(kHelmet)) GTEST_SKIP() << "asset missing: " << kHelmet;
  // Encoders and the quality pass both fail to write; the bake reports an
  // error (no crash, no hang) and the renderer stays usable.
  const fs::path missing = fs::temp_directory_path() / ("impostor_overlap_missing_" + std::to_string(::getpid()));
  fs::remove_all(missing);
  auto failed = Bake(Params(), missing / "no" / "such" / "dir", /*serial=*/false);
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.status().code(), absl::StatusCode::kOk);
  const fs::path dir = ScratchDir("after_failure");
  auto again = Bake(Params(), dir, /*serial=*/false);
  ASSERT_TRUE(again.ok()) << again.status();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace impostor
