// LoadGltfScene on malformed and hostile inputs: every one is a status with
// a message naming the problem, never a crash or a hang.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "tests/scene/test_assets.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::Asset;
using testing::TriangleGltf;
using testing::TriangleOptions;
using testing::WriteFile;

struct BadCase {
  std::string name;
  // Returns the entry file to load (may create it under `dir`).
  std::function<fs::path(const fs::path& dir)> make;
  absl::StatusCode code;
  std::string needle;  // must appear in the message
};

std::vector<BadCase> Cases() {
  std::vector<BadCase> cases;
  cases.push_back({"sanity: the generated triangle loads",
                   [](const fs::path& dir) {
                     WriteFile(dir / "ok.gltf", TriangleGltf({}));
                     return dir / "ok.gltf";
                   },
                   absl::StatusCode::kOk, ""});
  cases.push_back({"truncated GLB",
                   [](const fs::path& dir) {
                     std::ifstream in(Asset("props_pbr/Box/glTF-Binary/Box.glb"), std::ios::binary);
                     std::string bytes((std::istreambuf_iterator<char>(in)), {});
                     WriteFile(dir / "box.glb", bytes.substr(0, bytes.size() / 2));
                     return dir / "box.glb";
                   },
                   absl::StatusCode::kInvalidArgument, "cannot parse 'box.glb'"});
  cases.push_back({"empty file",
                   [](const fs::path& dir) {
                     WriteFile(dir / "empty.glb", "");
                     return dir / "empty.glb";
                   },
                   absl::StatusCode::kInvalidArgument, "is empty"});
  cases.push_back({"invalid JSON",
                   [](const fs::path& dir) {
                     WriteFile(dir / "bad.gltf", "{ \"asset\": {\"version\": \"2.0\"}, nope ");
                     return dir / "bad.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "cannot parse 'bad.gltf'"});
  cases.push_back({"deeply nested JSON",
                   [](const fs::path& dir) {
                     WriteFile(dir / "deep.gltf",
                               "{\"asset\": {\"version\": \"2.0\"}, \"extras\": " +
                                   std::string(100000, '[') + std::string(100000, ']') + "}");
                     return dir / "deep.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "nested deeper than"});
  cases.push_back({"buffer uri escaping the directory",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.buffer_uri = "../../etc/passwd";
                     WriteFile(dir / "escape.gltf", TriangleGltf(o));
                     return dir / "escape.gltf";
                   },
                   absl::StatusCode::kInvalidArgument,
                   "buffer[0]: uri '../../etc/passwd' resolves outside the asset directory"});
  cases.push_back({"percent-encoded escape",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.buffer_uri = "%2e%2e/%2e%2e/etc/passwd";
                     WriteFile(dir / "escape.gltf", TriangleGltf(o));
                     return dir / "escape.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "resolves outside the asset directory"});
  cases.push_back({"absolute uri",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.buffer_uri = "/etc/passwd";
                     WriteFile(dir / "abs.gltf", TriangleGltf(o));
                     return dir / "abs.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "absolute uri '/etc/passwd'"});
  cases.push_back({"file: scheme",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.buffer_uri = "file:///etc/passwd";
                     WriteFile(dir / "scheme.gltf", TriangleGltf(o));
                     return dir / "scheme.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "has a scheme"});
  cases.push_back({"symlink leading out",
                   [](const fs::path& dir) {
                     fs::create_directories(dir / "asset");
                     fs::create_symlink("/etc/passwd", dir / "asset" / "data.bin");
                     TriangleOptions o;
                     o.buffer_uri = "data.bin";
                     WriteFile(dir / "asset" / "link.gltf", TriangleGltf(o));
                     return dir / "asset" / "link.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "resolves outside the asset directory"});
  cases.push_back({"missing buffer file",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.buffer_uri = "gone.bin";
                     WriteFile(dir / "missing.gltf", TriangleGltf(o));
                     return dir / "missing.gltf";
                   },
                   absl::StatusCode::kInvalidArgument,
                   "buffer[0] refers to missing file 'gone.bin'"});
  cases.push_back({"index out of range",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.indices = {0, 1, 7};
                     WriteFile(dir / "oob.gltf", TriangleGltf(o));
                     return dir / "oob.gltf";
                   },
                   absl::StatusCode::kInvalidArgument,
                   "mesh 0 '' primitive 0 indices (accessor 1): index 7 at position 2 is out of "
                   "range (vertex count 3)"});
  cases.push_back(
      {"missing texture file",
       [](const fs::path&) {
         return Asset("edge_cases/missing_textures/BoxTextured_png_removed/BoxTextured.gltf");
       },
       absl::StatusCode::kInvalidArgument, "image[0] refers to missing file 'CesiumLogoFlat.png'"});
  cases.push_back({"Draco required",
                   [](const fs::path&) { return Asset("props_pbr/Box/glTF-Draco/Box.gltf"); },
                   absl::StatusCode::kInvalidArgument,
                   "extensionsRequired: KHR_draco_mesh_compression is not supported"});
  cases.push_back({"node cycle",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.nodes = R"([{"mesh": 0}, {"children": [2]}, {"children": [1]}])";
                     WriteFile(dir / "cycle.gltf", TriangleGltf(o));
                     return dir / "cycle.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "node cycle: nodes 1 <- 2 <- 1"});
  cases.push_back({"node with two parents",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.nodes = R"([{"children": [2]}, {"children": [2]}, {"mesh": 0}])";
                     o.scene_nodes = "[0, 1]";
                     WriteFile(dir / "parents.gltf", TriangleGltf(o));
                     return dir / "parents.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "node 2 has more than one parent"});
  cases.push_back({"node is its own child",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.nodes = R"([{"mesh": 0, "children": [0]}])";
                     WriteFile(dir / "self.gltf", TriangleGltf(o));
                     return dir / "self.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "node cycle"});
  cases.push_back({"no triangles in the default scene",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.nodes = R"([{}])";
                     WriteFile(dir / "empty_scene.gltf", TriangleGltf(o));
                     return dir / "empty_scene.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "no triangles in the default scene"});
  cases.push_back({"unsupported required extension",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.extra_top_level = R"("extensionsRequired": ["EXT_meshopt_compression"],)";
                     WriteFile(dir / "meshopt.gltf", TriangleGltf(o));
                     return dir / "meshopt.gltf";
                   },
                   absl::StatusCode::kInvalidArgument,
                   "extensionsRequired: EXT_meshopt_compression is not supported"});
  cases.push_back({"mesh index out of range",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.nodes = R"([{"mesh": 9}])";
                     WriteFile(dir / "mesh.gltf", TriangleGltf(o));
                     return dir / "mesh.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "uses mesh 9 which does not exist"});
  cases.push_back({"non-finite node transform",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.nodes = R"([{"mesh": 0, "scale": [1e308, 1e308, 1e308],
                                    "children": [1]}, {"scale": [1e308, 1, 1], "mesh": 0}])";
                     WriteFile(dir / "inf.gltf", TriangleGltf(o));
                     return dir / "inf.gltf";
                   },
                   absl::StatusCode::kInvalidArgument, "non-finite"});
  cases.push_back({"hierarchy deeper than max_node_depth",
                   [](const fs::path& dir) {
                     TriangleOptions o;
                     o.nodes = "[";
                     for (int i = 0; i < 2000; ++i) {
                       o.nodes += "{\"children\": [" + std::to_string(i + 1) + "]},";
                     }
                     o.nodes += "{\"mesh\": 0}]";
                     WriteFile(dir / "deep_nodes.gltf", TriangleGltf(o));
                     return dir / "deep_nodes.gltf";
                   },
                   absl::StatusCode::kInvalidArgument,
                   "deeper than GltfLoadLimits::max_node_depth = 1024"});
  cases.push_back({"not a file", [](const fs::path& dir) { return dir / "nothing_here.glb"; },
                   absl::StatusCode::kNotFound, "does not exist"});
  return cases;
}

TEST(GltfBadInputTest, EachCaseFailsWithANamedReason) {
  ASSERT_TRUE(fs::exists(testing::AssetsDir())) << "test assets missing: " << testing::AssetsDir();
  for (const BadCase& c : Cases()) {
    const fs::path dir = testing::MakeScratchDir("bad");
    const fs::path entry = c.make(dir);
    const absl::StatusOr<Scene> scene = LoadGltfScene(entry);
    EXPECT_EQ(scene.status().code(), c.code) << "case '" << c.name << "': " << scene.status();
    EXPECT_NE(std::string(scene.status().message()).find(c.needle), std::string::npos)
        << "case '" << c.name << "': message \"" << scene.status().message() << "\" lacks \""
        << c.needle << "\"";
    fs::remove_all(dir);
  }
}

// The Khronos glTF-Validator corpus: hundreds of malformed files. The loader
// must return (ok, or an error with a message) for every one; the slowest is
// reported (a hang is caught by the test's ctest timeout; speed is bench/
// material, not a pass/fail threshold on a shared machine).
TEST(GltfBadInputTest, ValidatorCorpusNeverCrashesOrHangs) {
  const fs::path root = Asset("edge_cases/gltf-validator-tests");
  ASSERT_TRUE(fs::exists(root)) << "validator corpus missing: " << root;
  // IMPOSTOR_VERBOSE_SWEEP=1 prints every file's outcome.
  const bool verbose = std::getenv("IMPOSTOR_VERBOSE_SWEEP") != nullptr;
  int ok = 0, failed = 0;
  double slowest_ms = 0;
  std::string slowest;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    const fs::path& p = entry.path();
    if (p.extension() != ".gltf" && p.extension() != ".glb") continue;
    const std::string rel = fs::relative(p, root).string();
    const auto start = std::chrono::steady_clock::now();
    const absl::StatusOr<Scene> scene = LoadGltfScene(p);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (ms > slowest_ms) {
      slowest_ms = ms;
      slowest = rel;
    }
    if (verbose) {
      std::printf("[ sweep  ] %s: %s\n", rel.c_str(),
                  scene.ok() ? "ok" : std::string(scene.status().message()).c_str());
    }
    if (scene.ok()) {
      ++ok;
      EXPECT_GT(scene->TriangleCount(), 0u) << rel;
    } else {
      ++failed;
      EXPECT_FALSE(scene.status().message().empty()) << rel;
    }
  }
  std::printf("[ info   ] validator corpus: %d loaded, %d refused; slowest %s (%.1f ms)\n", ok,
              failed, slowest.c_str(), slowest_ms);
  EXPECT_GT(ok + failed, 250);
  // Files that are broken at container/JSON/reference level must be refused.
  for (const char* rel :
       {"base/data/glb/invalid_magic.glb", "base/data/glb/empty_file.glb",
        "base/data/json/invalid_syntax.gltf", "base/data/buffer/not_found.gltf",
        "base/data/buffer/non_relative_uri.gltf", "base/data/node/node_loop.gltf"}) {
    const fs::path p = root / rel;
    if (!fs::exists(p)) {
      ADD_FAILURE() << "expected corpus file missing: " << rel;
      continue;
    }
    const absl::StatusOr<Scene> scene = LoadGltfScene(p);
    EXPECT_FALSE(scene.ok()) << rel;
    std::printf("[ info   ] %s: %s\n", rel, std::string(scene.status().message()).c_str());
  }
}

// Deterministic mutation fuzzing: random byte flips, truncations and
// duplicated spans of real files. Each mutant must give a status, not a
// crash (run under ASan/UBSan to make this test bite harder).
TEST(GltfBadInputTest, MutatedFilesNeverCrash) {
  const char* seeds[] = {"props_pbr/Box/glTF-Binary/Box.glb",
                         "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb",
                         "edge_cases/khronos/SimpleSparseAccessor/glTF/SimpleSparseAccessor.gltf",
                         "edge_cases/khronos/MeshPrimitiveModes/glTF/MeshPrimitiveModes.gltf"};
  std::mt19937 rng(1234);
  int mutants = 0, loaded = 0;
  constexpr int kMutantsPerSeed = 150;
  for (const char* rel : seeds) {
    const fs::path src = Asset(rel);
    // A missing seed would make this test pass without testing anything.
    ASSERT_TRUE(fs::exists(src)) << "seed file missing: " << src;
    std::ifstream in(src, std::ios::binary);
    const std::string original((std::istreambuf_iterator<char>(in)), {});
    ASSERT_FALSE(original.empty()) << rel;
    const fs::path dir = testing::MakeScratchDir("fuzz");
    // The seed's own buffers and images beside it, so that mutants of a
    // .gltf get past resolving its external files into the parts that read them.
    for (const auto& sibling : fs::directory_iterator(src.parent_path())) {
      if (sibling.is_regular_file() && sibling.path() != src) fs::copy_file(sibling.path(), dir / sibling.path().filename());
    }
    const fs::path entry = dir / src.filename();
    WriteFile(entry, original);
    const absl::StatusOr<Scene> unmutated = LoadGltfScene(entry);
    ASSERT_TRUE(unmutated.ok()) << rel << ": the seed itself must load: " << unmutated.status();
    for (int i = 0; i < kMutantsPerSeed; ++i) {
      std::string bytes = original;
      const int kind = static_cast<int>(rng() % 4);
      if (kind == 0) {  // flip a few bytes
        for (int k = 0; k < 1 + static_cast<int>(rng() % 8); ++k) {
          bytes[rng() % bytes.size()] = static_cast<char>(rng());
        }
      } else if (kind == 1) {  // truncate
        bytes.resize(rng() % bytes.size());
      } else if (kind == 2) {  // overwrite a digit in the JSON part (indices, counts, offsets)
        for (int k = 0; k < 4; ++k) {
          const size_t at = rng() % std::min<size_t>(bytes.size(), 4096);
          if (bytes[at] >= '0' && bytes[at] <= '9') bytes[at] = static_cast<char>('0' + rng() % 10);
          if (bytes[at] == '0') bytes.insert(at, "99999");
        }
      } else {  // duplicate a span
        const size_t from = rng() % bytes.size();
        const size_t len = std::min<size_t>(rng() % 64, bytes.size() - from);
        bytes.insert(rng() % bytes.size(), bytes.substr(from, len));
      }
      WriteFile(entry, bytes);
      const absl::StatusOr<Scene> scene = LoadGltfScene(entry);
      ++mutants;
      if (scene.ok()) {
        ++loaded;
        for (uint32_t index : scene->indices) ASSERT_LT(index, scene->vertices.size()) << rel << " mutant " << i;
      } else {
        EXPECT_FALSE(scene.status().message().empty()) << rel << " mutant " << i;
      }
    }
    fs::remove_all(dir);
  }
  EXPECT_EQ(mutants, kMutantsPerSeed * static_cast<int>(std::size(seeds)));
  std::printf("[ info   ] %d mutants, %d still loaded\n", mutants, loaded);
}

}  // namespace
}  // namespace impostor
