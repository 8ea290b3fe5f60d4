// libFuzzer target over DecodeScene (worker/scene/scene_wire.h): the bytes a
// compromised isolated-load child could hand the worker. Each input is taken
// as the bytes after the format's magic, so the fuzzer starts past it.
//
// Beyond the sanitizers' checks (no read past the input, no allocation the
// input did not pay for: -rss_limit_mb), it traps when DecodeScene breaks
// its contract: a failure other than DATA_LOSS, or a scene it accepts that
// breaks an invariant the bake relies on (CheckSceneInvariants).
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "worker/scene/scene_invariants.h"
#include "worker/scene/scene_wire.h"

namespace {

[[noreturn]] void Fail(const char* what, const absl::Status& status) {
  std::fprintf(stderr, "scene_wire_fuzzer: %s: %s\n", what, status.ToString().c_str());
  __builtin_trap();
}

// The magic EncodeScene writes first.
std::string Magic() {
  impostor::Scene empty;
  std::string bytes;
  impostor::EncodeScene(empty, &bytes);
  return bytes.substr(0, 8);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string magic = Magic();
  std::string bytes = magic;
  bytes.append(reinterpret_cast<const char*>(data), size);
  const absl::StatusOr<impostor::Scene> scene =
      impostor::DecodeScene({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()});
  if (!scene.ok()) {
    if (scene.status().code() != absl::StatusCode::kDataLoss) Fail("not DATA_LOSS", scene.status());
    return 0;
  }
  if (absl::Status s = impostor::CheckSceneInvariants(*scene); !s.ok()) Fail("accepted a broken scene", s);
  return 0;
}
