// The committed hostile corpus (tests/hostile/corpus/, each file a few
// hundred bytes of glTF JSON) and what loading each must end with. Shared by
// the in-process loader test (tests/scene/load_budget_test.cc) and the
// end-to-end worker test (tests/hostile/hostile_worker_test.cc), so both
// hold the same file to the same outcome. Line numbers in `why` are those of
// commit 449b765, before the fix.
#ifndef IMPOSTOR_TESTS_HOSTILE_HOSTILE_CASES_H_
#define IMPOSTOR_TESTS_HOSTILE_HOSTILE_CASES_H_

#include <cstdint>
#include <filesystem>

namespace impostor::testing {

struct HostileCase {
  const char* file;    // under HostileCorpusDir()
  int code;            // absl::StatusCode / grpc::StatusCode value (they agree)
  const char* needle;  // must appear in the error message
  const char* why;     // what it attacks, and the line it used to reach
};

inline constexpr int kInvalidArgument = 3;
inline constexpr int kResourceExhausted = 8;

// Peak resident memory a load (or a worker serving these jobs) may reach.
// Before the load budget, instancing_60m_no_bufferview.gltf alone took a
// worker past 11 GB.
inline constexpr uint64_t kPeakRssBound = uint64_t{1} << 30;

inline constexpr HostileCase kHostileCases[] = {
    {"instancing_60m_no_bufferview.gltf", kResourceExhausted,
     "60000000 instances x 1 primitives = 60000000 draws",
     "the issue 23 reproduction: EXT_mesh_gpu_instancing TRANSLATION without a bufferView; "
     "gltf_scene_builder.cc:338 reserved a dmat4 per instance (7.7 GB) after "
     "gltf_accessor.cc:276 assigned 60,000,000 x 3 floats"},
    {"two_nodes_600k_instances.gltf", kResourceExhausted, "GltfLoadLimits::max_draws = 1000000",
     "instances x primitives summed over nodes"},
    {"position_100m_no_bufferview.gltf", kResourceExhausted, "100000000 vertices",
     "POSITION count with no bufferView: gltf_accessor.cc:283 sized its output from count "
     "alone"},
    {"normal_60m_next_to_3_positions.gltf", kInvalidArgument,
     "has 60000000 elements but POSITION has 3",
     "gltf_scene_builder.cc:466 read NORMAL (720 MB of zeros) before comparing counts"},
    {"indices_4g_no_bufferview.gltf", kInvalidArgument, "accessor[1] invalid bufferView",
     "4,000,000,000 indices declared, no data: tinygltf itself refuses an index accessor "
     "without a bufferView"},
    {"strip_60m_positions.gltf", kResourceExhausted,
     "1 instances x 60000000 triangles = 60000000 triangles",
     "a non-indexed triangle strip's n - 2 triangles, POSITION without a bufferView"},
    {"morph_1000_targets_x_100k.gltf", kResourceExhausted,
     "1000 morph targets x 100000 vertices = 100000000 morph target elements",
     "gltf_scene_builder.cc:574 read every weighted morph target in full"},
    {"sparse_50m_positions.gltf", kResourceExhausted, "GltfLoadLimits::max_load_bytes",
     "a sparse accessor: 50,000,000 zero elements around one substitution"},
    {"png_header_16384_rgba16.gltf", kResourceExhausted, "GltfLoadLimits::max_load_bytes",
     "a 16-bit RGBA PNG header of 16384x16384: texture_decode.cc:66 counted 4 bytes per "
     "pixel, the decode peaks at 40"},
    {"glb_buffer_bytelength_0.glb", kInvalidArgument, "buffer[0]: byteLength 0 is below the minimum 1",
     "found by fuzz/run.sh (88 bytes): a GLB whose buffer 0 has byteLength 0 next to a 4-byte BIN "
     "chunk; tinygltf's ParseBuffer threw std::out_of_range from vector::at and the uncaught "
     "exception ended the process"},
};

inline std::filesystem::path HostileCorpusDir() { return IMPOSTOR_HOSTILE_CORPUS_DIR; }

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_HOSTILE_HOSTILE_CASES_H_
