// Input path collisions (common/request/input_paths.h), refused by ValidateMeshInput
// and therefore by SubmitBake before a job exists. Before this check
// ["a", "a/b.png"] passed, and the worker's create_directories threw while
// its heartbeat thread ran: the process terminated, on every retry, on every
// worker that leased the job (issue 23).
#include "common/request/input_paths.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/request/bake_request.h"
#include "common/util/sha256.h"

namespace impostor {
namespace {

v1::MeshInput Mesh(const std::string& entry, const std::vector<std::string>& files) {
  v1::MeshInput m;
  auto set = [](v1::InputFile* f, const std::string& path) {
    f->set_path(path);
    f->mutable_digest()->set_hash(Sha256Hex(path));
    f->mutable_digest()->set_size_bytes(static_cast<int64_t>(path.size()));
  };
  set(m.mutable_entry(), entry);
  for (const std::string& path : files) set(m.add_files(), path);
  return m;
}

TEST(InputPaths, CollisionsAreRefusedNamingBothPaths) {
  struct Case {
    const char* name;
    std::string entry;
    std::vector<std::string> files;
    std::vector<std::string> needles;  // all must appear in the message
  };
  const std::vector<Case> cases = {
      {"file is another's directory", "m.gltf", {"a", "a/b.png"},
       {"mesh.files[1].path \"a/b.png\" needs \"a\" as a directory",
        "mesh.files[0].path \"a\" is a file there"}},
      {"directory listed after", "m.gltf", {"tex/x/y.png", "tex/x"},
       {"\"tex/x/y.png\" needs \"tex/x\"", "mesh.files[1].path \"tex/x\""}},
      {"case-only difference", "m.gltf", {"Tex.png", "tex.png"},
       {"mesh.files[1].path \"tex.png\" and mesh.files[0].path \"Tex.png\" differ only in case"}},
      {"case-folded prefix", "m.gltf", {"A", "a/b.png"}, {"needs \"a\" as a directory"}},
      {"exact duplicate", "m.gltf", {"x.bin", "x.bin"}, {"name the same file"}},
      {"file overwrites the entry", "m.gltf", {"m.gltf"}, {"mesh.entry.path", "name the same file"}},
      {"entry's file name, not its path", "models/m.gltf", {"M.GLTF"}, {"differ only in case"}},
      {"inside the entry", "m.gltf", {"m.gltf/x.png"}, {"needs \"m.gltf\" as a directory"}},
  };
  for (const Case& c : cases) {
    const absl::Status s = ValidateMeshInput(Mesh(c.entry, c.files));
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.name << ": " << s;
    for (const std::string& needle : c.needles) {
      EXPECT_NE(s.message().find(needle), std::string::npos) << c.name << ": " << s;
    }
  }
}

TEST(InputPaths, OtherSpellingsOfOnePathAreRefusedAsUnsafe) {
  // "./a", "a/", "a//b" and "a/../b" never reach the collision check.
  for (const char* path : {"./a", "a/", "a//b", "a/../b", "a/./b"}) {
    const absl::Status s = ValidateMeshInput(Mesh("m.gltf", {"a.bin", path}));
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << path;
    EXPECT_NE(s.message().find("mesh.files[1].path"), std::string::npos) << path << ": " << s;
  }
}

TEST(InputPaths, DisjointInputsPass) {
  EXPECT_TRUE(ValidateMeshInput(Mesh("m.gltf", {"a.png", "ab/b.png", "a2/c.png", "m.bin", "textures/m.gltf"})).ok());
  EXPECT_EQ(EntryDiskPath(Mesh("models/m.gltf", {})), "m.gltf");
}

}  // namespace
}  // namespace impostor
