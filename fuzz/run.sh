#!/usr/bin/env bash
# Builds the libFuzzer targets with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer in their own build folder, and runs
# gltf_load_fuzzer for FUZZ_SECONDS (default 60) from a seed corpus of every
# small .glb/.gltf under the shared assets and tests/hostile/corpus/, then
# scene_wire_fuzzer for FUZZ_SCENE_RUNS (default 300000, seconds) runs. Exits
# non-zero if the fuzzer finds a crash, a sanitizer report, a leak, a timeout
# or an out-of-memory input; the input is kept under FUZZ_BUILD_DIR/artifacts/.
#
# CI runs a fixed number of executions from a fixed seed (FUZZ_RUNS,
# FUZZ_SEED), so the same commit explores the same inputs on every machine and
# a red CI always points at a reproducible finding; FUZZ_SECONDS bounds the
# time on a slow machine. Exploratory runs: FUZZ_RUNS=-1 FUZZ_SEED=0 (random)
# with a longer FUZZ_SECONDS.
#
#   FUZZ_RUNS=-1 FUZZ_SEED=0 FUZZ_SECONDS=600 bash fuzz/run.sh   # a longer, random run
#   bash fuzz/run.sh path/to/crash-input                        # replay one input
#   FUZZ_TARGET=scene_wire_fuzzer bash fuzz/run.sh crash-input   # replay one for the scene bytes fuzzer
set -euo pipefail
cd "$(dirname "$0")/.."
FUZZ_SECONDS=${FUZZ_SECONDS:-120}
FUZZ_RUNS=${FUZZ_RUNS:-40000}
FUZZ_SEED=${FUZZ_SEED:-1}
FUZZ_BUILD_DIR=${FUZZ_BUILD_DIR:-build-fuzz}
ASSETS_DIR=${IMPOSTOR_ASSETS_DIR:-../shared/assets}
JOBS=${JOBS:-2}
# Inputs larger than this are neither seeds nor generated: big textures make
# each execution slow without reaching new code.
MAX_LEN=131072

for tool in clang-14 clang++-14; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "fuzz/run.sh: $tool not found (bash deploy/install-deps.sh installs it)" >&2
    exit 1
  fi
done

sanitize="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer"
generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
# Only the loader and what it needs: no gRPC, Vulkan, server or tests.
CC=clang-14 CXX=clang++-14 cmake -S . -B "$FUZZ_BUILD_DIR" "${generator[@]}" -Wno-dev \
  -DCMAKE_BUILD_TYPE=Fuzz \
  -DCMAKE_C_FLAGS="-O1 -g $sanitize" -DCMAKE_CXX_FLAGS="-O1 -g $sanitize" \
  -DIMPOSTOR_COMPONENTS="common;worker/scene" -DIMPOSTOR_BUILD_FUZZERS=ON \
  -DIMPOSTOR_BUILD_TESTS=OFF -DIMPOSTOR_BUILD_BENCH=OFF >/dev/null
cmake --build "$FUZZ_BUILD_DIR" --target gltf_load_fuzzer scene_wire_fuzzer -j "$JOBS"
fuzzer="$FUZZ_BUILD_DIR/bin/${FUZZ_TARGET:-gltf_load_fuzzer}"

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
mkdir -p "$FUZZ_BUILD_DIR/artifacts"
# The load budget (FuzzLimits' max_load_bytes = 256 MiB) keeps every input
# far below this; an input that reaches it is a budget the loader escaped.
flags=(-max_len="$MAX_LEN" -rss_limit_mb=1024 -timeout=10 -print_final_stats=1
       -dict=fuzz/gltf.dict -artifact_prefix="$FUZZ_BUILD_DIR/artifacts/")

if [ $# -gt 0 ]; then
  exec "$fuzzer" "${flags[@]}" "$@"
fi

# The scene the isolated loader's child hands back (worker/scene/scene_wire.h),
# from an empty corpus: the target starts past the format's magic.
FUZZ_SCENE_RUNS=${FUZZ_SCENE_RUNS:-300000}
echo "fuzz/run.sh: scene_wire_fuzzer, ${FUZZ_SCENE_RUNS} runs (seed ${FUZZ_SEED})"
"$FUZZ_BUILD_DIR/bin/scene_wire_fuzzer" -max_len=4096 -rss_limit_mb=1024 -timeout=10 -print_final_stats=1 \
  -artifact_prefix="$FUZZ_BUILD_DIR/artifacts/" -runs="$FUZZ_SCENE_RUNS" -seed="$FUZZ_SEED" \
  -max_total_time="$FUZZ_SECONDS"

# The seed corpus is made fresh each run and never committed: assets stay in
# the shared folder.
corpus=$(mktemp -d)
trap 'rm -rf "$corpus"' EXIT
# The committed hostile corpus (tests/hostile/corpus/, issue 23) seeds the
# resource-bomb shapes the load budget must refuse.
find "$ASSETS_DIR" tests/hostile/corpus -type f \( -iname '*.glb' -o -iname '*.gltf' \) -size -"$MAX_LEN"c -print0 |
  while IFS= read -r -d '' f; do
    cp "$f" "$corpus/$(sha256sum "$f" | cut -c1-16)"
  done
echo "fuzz/run.sh: $(ls "$corpus" | wc -l) seeds from $ASSETS_DIR, ${FUZZ_RUNS} runs (seed ${FUZZ_SEED}), at most ${FUZZ_SECONDS}s"
"$fuzzer" "${flags[@]}" -runs="$FUZZ_RUNS" -seed="$FUZZ_SEED" -max_total_time="$FUZZ_SECONDS" "$corpus"
