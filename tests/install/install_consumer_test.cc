// The SDK as a user gets it: `cmake --install --component lib` and `sdk` into a staged
// prefix, then the stand-alone example projects (examples/consumer in C++,
// examples/c in C, and the C example once more through pkg-config) are
// configured and built against that prefix alone, and run against a real
// impostor-server holding a published result. Asserts the fetched files'
// digests, the frames the runtime math picks, and what the installed tree
// holds and hides.
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "impostor/runtime.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

// The tool runs of this file: configure and build steps print a lot; on
// failure the whole output is the useful part.
std::string Describe(const ToolRun& run) { return "exit " + std::to_string(run.exit_code) + "\n" + run.out + run.err; }

class InstallTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    work_ = fs::path(IMPOSTOR_INSTALL_TEST_DIR) / info->name();
    fs::remove_all(work_);
    fs::create_directories(work_);
    prefix_ = work_ / "prefix";
    // `lib` (the versioned shared objects) and `sdk` (links, headers, CMake
    // and pkg-config files): the contents of libimpostor0.1 + libimpostor-dev.
    for (const char* component : {"lib", "sdk"}) {
      const ToolRun install = RunTool({IMPOSTOR_CMAKE_COMMAND, "--install", IMPOSTOR_BUILD_DIR, "--component",
                                       component, "--prefix", prefix_.string()});
      ASSERT_EQ(install.exit_code, 0) << component << ": " << Describe(install);
    }
  }

  // Configures and builds the example project in `source` against the
  // staged prefix only; returns the build directory.
  fs::path BuildExample(const fs::path& source) {
    const fs::path build = work_ / (source.filename().string() + "-build");
    const ToolRun configure = RunTool({IMPOSTOR_CMAKE_COMMAND, "-S", source.string(), "-B", build.string(), "-G",
                                       IMPOSTOR_CMAKE_GENERATOR, "-DCMAKE_BUILD_TYPE=Release",
                                       "-DCMAKE_PREFIX_PATH=" + prefix_.string(),
                                       "-DCMAKE_C_COMPILER=" IMPOSTOR_C_COMPILER,
                                       "-DCMAKE_CXX_COMPILER=" IMPOSTOR_CXX_COMPILER});
    EXPECT_EQ(configure.exit_code, 0) << Describe(configure);
    // The package must have come from the staged prefix, not the build tree.
    std::ifstream cache(build / "CMakeCache.txt");
    std::stringstream text;
    text << cache.rdbuf();
    EXPECT_NE(text.str().find("impostor_DIR:PATH=" + (prefix_ / "lib/cmake/impostor").string()), std::string::npos)
        << text.str().substr(0, 4000);
    const ToolRun compile = RunTool({IMPOSTOR_CMAKE_COMMAND, "--build", build.string()});
    EXPECT_EQ(compile.exit_code, 0) << Describe(compile);
    return build;
  }

  fs::path work_;
  fs::path prefix_;
};

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST_F(InstallTest, InstalledTreeHoldsThePackageAndHidesTheInternals) {
  for (const char* file : {"include/impostor/client.h", "include/impostor/cache.h", "include/impostor/runtime.h",
                           "include/impostor/lod.h", "include/impostor/impostor_c.h", "lib/libimpostor.so", "lib/libimpostor_runtime.so",
                           "lib/cmake/impostor/impostorConfig.cmake", "lib/cmake/impostor/impostorConfigVersion.cmake",
                           "lib/cmake/impostor/impostorTargets.cmake", "lib/pkgconfig/impostor.pc"}) {
    EXPECT_TRUE(fs::exists(prefix_ / file)) << file;
  }
  // The reference GLSL runtime, as in the source tree (docs/runtime.md).
  for (const char* shader : {"impostor_runtime.glsl", "impostor_crossfade.glsl", "impostor_material.glsl",
                             "impostor_material_light.glsl"}) {
    EXPECT_EQ(ReadFile(prefix_ / "share/impostor/shaders" / shader),
              ReadFile(fs::path(IMPOSTOR_SOURCE_DIR) / "shaders" / shader))
        << shader;
  }
  // The documents the headers name, where the headers say they are.
  for (const char* doc : {"manifest_format.md", "cache_layout.md", "runtime.md", "ktx2.md"}) {
    EXPECT_TRUE(fs::exists(prefix_ / "share/doc/impostor" / doc)) << doc;
  }
  for (const auto& entry : fs::directory_iterator(prefix_ / "include/impostor")) {
    const std::string text = ReadFile(entry.path());
    for (const char* source_only : {"common/", "client/cache/", "docs/"}) {
      EXPECT_EQ(text.find(source_only), std::string::npos)
          << entry.path() << " names " << source_only << ", which is not installed";
    }
  }
  // Public headers include no gRPC, protobuf or private header.
  for (const auto& entry : fs::directory_iterator(prefix_ / "include/impostor")) {
    std::ifstream in(entry.path());
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("#include", 0) != 0) continue;
      EXPECT_EQ(line.find("grpc"), std::string::npos) << entry.path() << ": " << line;
      EXPECT_EQ(line.find("google/protobuf"), std::string::npos) << entry.path() << ": " << line;
      EXPECT_TRUE(line.find('<') != std::string::npos || line.find("\"absl/") != std::string::npos ||
                  line.find("\"impostor/") != std::string::npos)
          << entry.path() << ": " << line;
    }
  }
  // The library exports the C API and impostor::sdk, not the protobuf code
  // or anything of gRPC's.
  const ToolRun nm = RunTool({"/bin/sh", "-c", "nm -DC --defined-only \"$0\"", (prefix_ / "lib/libimpostor.so").string()});
  ASSERT_EQ(nm.exit_code, 0) << Describe(nm);
  EXPECT_NE(nm.out.find(" impostor_cache_open"), std::string::npos);
  EXPECT_NE(nm.out.find("impostor::sdk::Cache::Open"), std::string::npos);
  // (Internal SDK functions may name those types in their parameters; what
  // must not be exported is a definition of theirs.)
  int exported = 0;
  for (std::string line : Lines(nm.out)) {
    const size_t name_at = line.find(' ', line.find(' ') + 1);
    ASSERT_NE(name_at, std::string::npos) << line;
    std::string name = line.substr(name_at + 1);
    for (const char* prefix : {"typeinfo name for ", "typeinfo for ", "vtable for "}) {
      if (name.rfind(prefix, 0) == 0) name = name.substr(std::strlen(prefix));
    }
    ++exported;
    EXPECT_TRUE(name.rfind("impostor_", 0) == 0 || name.rfind("impostor::sdk::", 0) == 0) << "exported: " << line;
  }
  EXPECT_GT(exported, 20);
  // The LOD chain API is in the runtime library (impostor::lod).
  const ToolRun runtime_nm =
      RunTool({"/bin/sh", "-c", "nm -DC --defined-only \"$0\"", (prefix_ / "lib/libimpostor_runtime.so").string()});
  ASSERT_EQ(runtime_nm.exit_code, 0) << Describe(runtime_nm);
  EXPECT_NE(runtime_nm.out.find("impostor::sdk::LoadLodChain"), std::string::npos);
  EXPECT_NE(runtime_nm.out.find("impostor::sdk::SelectLod"), std::string::npos);
}

TEST_F(InstallTest, CppConsumerFetchesThroughTheCacheAndPicksFrames) {
  const fs::path build = BuildExample(fs::path(IMPOSTOR_SOURCE_DIR) / "examples/consumer");
  ASSERT_FALSE(HasFailure());
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, {3000, 5000, 700}, 20);
  const fs::path cache_dir = work_ / "cache";

  const ToolRun first = RunTool({(build / "fetch_and_pick").string(), server.address(), cache_dir.string(), published.key});
  ASSERT_EQ(first.exit_code, 0) << Describe(first);
  // Every published file, with its SHA-256 and size; then the frames.
  std::vector<std::string> expected = {"key " + published.key + " downloaded"};
  const std::map<std::string, std::string> semantic_of = {{"albedo_alpha.png", "albedo_alpha"},
                                                          {"normal_depth.png", "normal_depth"},
                                                          {"orm.png", "orm"},
                                                          {"manifest.json", "manifest"}};
  std::vector<std::string> file_lines;
  for (const auto& [name, bytes] : published.files) {
    file_lines.push_back("file " + semantic_of.at(name) + " " + DigestOf(bytes).hash() + " " +
                         std::to_string(bytes.size()));
  }
  std::vector<std::string> actual = Lines(first.out);
  ASSERT_GE(actual.size(), 1 + file_lines.size()) << first.out;
  std::vector<std::string> actual_files(actual.begin() + 1, actual.begin() + 1 + file_lines.size());
  std::sort(actual_files.begin(), actual_files.end());
  std::sort(file_lines.begin(), file_lines.end());
  EXPECT_EQ(actual[0], expected[0]);
  EXPECT_EQ(actual_files, file_lines);

  // The picks, computed here by the SDK in this build tree: the installed
  // library must agree with it.
  std::vector<std::string> picks = {"layout octahedral frames 3 views 9"};
  const float views[][3] = {{0, 1, 0}, {1, 0, 0}, {1, 1, 1}, {0, -0.2f, -1}};
  for (const auto& view : views) {
    const sdk::FrameBlend blend = sdk::BlendFrames(sdk::Layout::kOctahedral, 3, view, sdk::BlendMode::kTriangle3);
    char line[256];
    int n = std::snprintf(line, sizeof(line), "pick %g %g %g:", view[0], view[1], view[2]);
    for (int i = 0; i < blend.count; ++i) {
      n += std::snprintf(line + n, sizeof(line) - n, " %d:%.4f", blend.entries[i].frame, blend.entries[i].weight);
    }
    picks.push_back(line);
  }
  EXPECT_EQ(std::vector<std::string>(actual.begin() + 1 + file_lines.size(), actual.end()), picks) << first.out;

  // Second run: the same result from disk, with the server gone.
  server.Kill();
  const ToolRun second = RunTool({(build / "fetch_and_pick").string(), server.address(), cache_dir.string(), published.key});
  ASSERT_EQ(second.exit_code, 0) << Describe(second);
  EXPECT_EQ(Lines(second.out).at(0), "key " + published.key + " from-disk");
}

TEST_F(InstallTest, CExampleBuildsWithCMakeAndWithPkgConfig) {
  const fs::path build = BuildExample(fs::path(IMPOSTOR_SOURCE_DIR) / "examples/c");
  ASSERT_FALSE(HasFailure());
  const fs::path by_pkg_config = work_ / "c_example_pkg_config";
  const ToolRun cc = RunTool(
      {"/bin/sh", "-c",
       "set -e; flags=$(PKG_CONFIG_PATH=\"$1/lib/pkgconfig\" pkg-config --cflags --libs impostor); "
       "echo \"$flags\"; \"$2\" -std=c99 -o \"$3\" \"$4\" $flags",
       "sh", prefix_.string(), IMPOSTOR_C_COMPILER, by_pkg_config.string(),
       (fs::path(IMPOSTOR_SOURCE_DIR) / "examples/c/cache_example.c").string()});
  ASSERT_EQ(cc.exit_code, 0) << Describe(cc);
  // The flags point into the staged prefix (the .pc file is relocatable).
  EXPECT_NE(cc.out.find("-L" + (prefix_ / "lib").string()), std::string::npos) << cc.out;

  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, {2000, 1000, 500}, 21);
  const ToolRun by_cmake =
      RunTool({(build / "impostor_c_example").string(), server.address(), (work_ / "cache").string(), published.key});
  ASSERT_EQ(by_cmake.exit_code, 0) << Describe(by_cmake);
  EXPECT_EQ(Lines(by_cmake.out).at(0).rfind(published.key + ": downloaded, " + std::to_string(published.total_bytes) +
                                                " bytes in ",
                                            0),
            0u)
      << by_cmake.out;
  // No RPATH into the staged prefix here: the loader is told where it is.
  const ToolRun by_pc = RunTool({by_pkg_config.string(), server.address(), (work_ / "cache").string(), published.key},
                                kExitTimeout, {"LD_LIBRARY_PATH=" + (prefix_ / "lib").string()});
  ASSERT_EQ(by_pc.exit_code, 0) << Describe(by_pc);
  EXPECT_EQ(Lines(by_pc.out).at(0).rfind(published.key + ": from disk, ", 0), 0u) << by_pc.out;
  EXPECT_NE(by_pc.out.find("albedo map: " + (work_ / "cache").string()), std::string::npos) << by_pc.out;
}

TEST_F(InstallTest, FindPackageRefusesAnIncompatibleVersion) {
  const fs::path project = work_ / "wants-99.0";
  fs::create_directories(project);
  std::ofstream(project / "CMakeLists.txt") << "cmake_minimum_required(VERSION 3.25)\n"
                                               "project(wants LANGUAGES CXX)\n"
                                               "find_package(impostor 99.0 CONFIG REQUIRED)\n";
  const ToolRun configure = RunTool({IMPOSTOR_CMAKE_COMMAND, "-S", project.string(), "-B", (work_ / "b").string(),
                                     "-DCMAKE_PREFIX_PATH=" + prefix_.string()});
  EXPECT_NE(configure.exit_code, 0) << Describe(configure);
  EXPECT_NE((configure.out + configure.err).find("impostorConfig.cmake, version: " IMPOSTOR_PROJECT_VERSION),
            std::string::npos)
      << Describe(configure);
}

// A game that uses only the runtime math (or the C API) needs no Abseil
// CMake package; one that asks for a component whose headers use Abseil's
// Status is told what is missing; an unknown component is named.
TEST_F(InstallTest, RuntimeOnlyConsumersNeedNoAbseil) {
  const fs::path main_cc = work_ / "main.cc";
  std::ofstream(main_cc) << "#include <impostor/runtime.h>\n"
                            "int main() { return impostor::sdk::FrameCount(impostor::sdk::AtlasLayout{}) >= 0 ? 0 : 1; }\n";
  struct Case {
    std::string name, find, link;
    bool configures;
    std::string message;  // in the configure output
    bool without_absl = true;
  };
  const std::string data_dir = "impostor_DATA_DIR=" + (prefix_ / "share/impostor").string();
  const Case cases[] = {
      {"components-runtime", "find_package(impostor CONFIG REQUIRED COMPONENTS runtime)", "impostor::runtime", true,
       data_dir},
      {"no-components", "find_package(impostor CONFIG REQUIRED)", "impostor::runtime", true, data_dir},
      {"components-cache", "find_package(impostor CONFIG REQUIRED COMPONENTS runtime cache)", "impostor::runtime", false,
       "absl"},
      {"unknown-component", "find_package(impostor CONFIG REQUIRED COMPONENTS shaders)", "impostor::runtime", false,
       "impostor has no component 'shaders'"},
      // With Abseil found after impostor's own paths: its config must not
      // move impostor_DATA_DIR to Abseil's prefix.
      {"with-abseil", "find_package(impostor CONFIG REQUIRED COMPONENTS cache runtime)", "impostor::runtime", true,
       data_dir, /*without_absl=*/false},
  };
  for (const Case& c : cases) {
    const fs::path project = work_ / c.name;
    fs::create_directories(project);
    std::ofstream(project / "CMakeLists.txt") << "cmake_minimum_required(VERSION 3.25)\n"
                                                 "project(game LANGUAGES CXX)\n"
                                              << c.find << "\nmessage(STATUS \"impostor_DATA_DIR=${impostor_DATA_DIR}\")"
                                              << "\nadd_executable(game " << main_cc.string()
                                              << ")\ntarget_link_libraries(game PRIVATE " << c.link << ")\n";
    const fs::path build = work_ / (c.name + "-build");
    const ToolRun configure = RunTool({IMPOSTOR_CMAKE_COMMAND, "-S", project.string(), "-B", build.string(), "-G",
                                       IMPOSTOR_CMAKE_GENERATOR, "-DCMAKE_PREFIX_PATH=" + prefix_.string(),
                                       std::string("-DCMAKE_DISABLE_FIND_PACKAGE_absl=") + (c.without_absl ? "ON" : "OFF"),
                                       "-DCMAKE_CXX_COMPILER=" IMPOSTOR_CXX_COMPILER});
    EXPECT_NE((configure.out + configure.err).find(c.message), std::string::npos) << c.name << ": " << Describe(configure);
    if (!c.configures) {
      EXPECT_NE(configure.exit_code, 0) << c.name << ": " << Describe(configure);
      continue;
    }
    ASSERT_EQ(configure.exit_code, 0) << c.name << ": " << Describe(configure);
    const ToolRun compile = RunTool({IMPOSTOR_CMAKE_COMMAND, "--build", build.string()});
    EXPECT_EQ(compile.exit_code, 0) << c.name << ": " << Describe(compile);
  }
}

// A whole-tree `cmake --install --prefix P` (no component) writes only
// inside P: the systemd units and /etc files are the packages' (and a
// component install's), not a developer's staging prefix's.
TEST_F(InstallTest, AWholeTreeInstallStaysInsideItsPrefix) {
  const fs::path whole = work_ / "whole";
  const ToolRun install = RunTool({IMPOSTOR_CMAKE_COMMAND, "--install", IMPOSTOR_BUILD_DIR, "--prefix", whole.string()});
  ASSERT_EQ(install.exit_code, 0) << Describe(install);
  int lines = 0;
  for (const std::string& line : Lines(install.out)) {
    const size_t at = line.find(": /");  // "-- Installing: /path" and "-- Up-to-date: /path"
    if (at == std::string::npos) continue;
    ++lines;
    EXPECT_EQ(line.compare(at + 2, whole.string().size(), whole.string()), 0) << line;
  }
  EXPECT_GT(lines, 20) << install.out;
  EXPECT_TRUE(fs::exists(whole / "bin/impostor-server"));
  EXPECT_TRUE(fs::exists(whole / "share/impostor/shaders/impostor_runtime.glsl"));
  fs::remove_all(whole);
}

}  // namespace
}  // namespace impostor::testing
