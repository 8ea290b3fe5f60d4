#!/bin/bash
# Runs on the GPU host, from the bundle's folder (bundle.sh), as root (it
# creates the folders the binaries were built to expect and, where the
# host lacks them, installs the glvnd libraries):
#
#   OUT=/tmp/results bash run.sh [e2e]
#
# A 15 s probe first: without a usable Vulkan device it prints the loader's
# errors and stops, instead of leaving the benches to wait for a worker.
# Then the end-to-end bench (bench/e2e_bench.sh: the CLI against a farm with
# one local worker, beside the in-process bake, and fetches beside nginx +
# curl) and the fleet bench on the host's cores; with `e2e` that is all
# (about a minute on an H200). Otherwise the other benches (timings) one by
# one, then the GPU suites side by side.
set -u
only=${1:-all}
here=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-$here/results}
mkdir -p "$OUT"
exec > >(tee -a "$OUT/log.txt") 2>&1
. "$here/paths.env"
root=/opt/impostor-gpu-check
rm -rf "$root" && mkdir -p "$root" "$ASSETS_DIR" "$(dirname "$BUILD_BIN")"
tar xJf "$here/pack.tar.xz" -C "$root"
tar xf "$here/assets.tar" -C "$ASSETS_DIR"
[ -e "$BUILD_BIN" ] || ln -s "$root/pack/bin" "$BUILD_BIN"
# The fleet bench starts nginx from Debian's path.
[ -e /usr/sbin/nginx ] || ln -s "$root/pack/bin/nginx" /usr/sbin/nginx
for f in "$here"/glvnd/*; do
  ldconfig -p | grep -q "$(basename "$f")" || cp "$f" /usr/lib/x86_64-linux-gnu/
done
ldconfig
# NVIDIA's containers keep the driver's manifest outside the loader's search path.
if [ -z "${VK_DRIVER_FILES:-}" ]; then
  icd=$(ls /usr/local/nvidia/share/vulkan/icd.d/*.json 2>/dev/null | head -1)
  [ -n "$icd" ] && export VK_DRIVER_FILES=$icd VK_ICD_FILENAMES=$icd
fi
export LD_LIBRARY_PATH=$root/pack/lib PATH=$root/pack/bin:$PATH
bin=$root/pack/bin
asset=$ASSETS_DIR/props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>/dev/null
if ! timeout 15 "$bin/gpu_tests" --gtest_filter=AtlasRendererTest.ReportsAVulkan13Device > "$OUT/probe.txt" 2>&1; then
  echo "gpu_check: no usable Vulkan device; the loader says:"
  VK_LOADER_DEBUG=error,driver timeout 15 "$bin/gpu_tests" --gtest_filter=AtlasRendererTest.ReportsAVulkan13Device 2>&1 |
    grep -E "ERROR|DRIVER|device" | head -20
  exit 1
fi
grep -m1 "using device" "$OUT/probe.txt"
cd /tmp
E2E_BENCH_COMMIT=${COMMIT:-?} MODEL=$asset TMPDIR=/tmp timeout 300 bash "$here/bench/e2e_bench.sh" "$root/pack" --warm 3 --fetch-pairs 5 --batch-assets 0
TMPDIR=/dev/shm timeout 150 "$bin/fleet_bench" --rounds 3 2>&1 | tail -4
[ "$only" = e2e ] && exit 0
suites=()
timeout 60 "$bin/bake_bench" --fetches 1 "$asset" 2>&1 | grep -v '^\[20\|^20' | tail -4
timeout 30 "$bin/bake_stages" "$asset" 2>&1 | grep -v '^\[20' | tail -4
timeout 30 "$bin/bake_stages" --quality-views 0 --keep /tmp/gpu_check_maps "$asset" 2>&1 | grep -v '^\[20' | tail -4
timeout 60 "$bin/png_bench" /tmp/gpu_check_maps/{albedo_alpha,normal_depth,orm}.png
# Issue 17's configuration: what the quality pass costs there (its own
# seconds, and the bake with and without it).
# Three bakes each, interleaved, so a slow first one or a noisy neighbour
# shows instead of deciding the share.
# BAKE_STAGES_DEBUG: the pass's per-step seconds (event=quality_pass_steps).
for round in 1 2 3; do
  BAKE_STAGES_DEBUG=1 timeout 30 "$bin/bake_stages" --layout hemi-octahedral "$asset" 2>&1 |
    grep -E '^run|event=quality_pass |event=quality_pass_steps' |
    sed 's/.*event=quality_pass .* impostor_views/quality pass: impostor_views/;s/.*event=quality_pass_steps[^=]*=[^=]*impostor_views=/steps: /;s/^run/with pass:    run/'
  timeout 30 "$bin/bake_stages" --layout hemi-octahedral --impostor-views cpu "$asset" 2>&1 |
    grep -E '^run|event=quality_pass ' | sed 's/.*event=quality_pass .* impostor_views/quality pass: impostor_views/;s/^run/pass on cpu:  run/'
  timeout 30 "$bin/bake_stages" --layout hemi-octahedral --quality-views 0 "$asset" 2>&1 | grep '^run' |
    sed 's/^run/without pass: run/'
done
# Issue 17's table rows (hemi-octahedral 12 x 12, 2048 px, 256 px views) on
# this device: every figure and the pass share per asset.
# --pass-cost 3: what the pass adds to each bake's wall time (it overlaps the
# encoders, so its own seconds overstate it), medians of three each way.
timeout 300 "$bin/metrics_bench" --runs 11
timeout 300 "$bin/quality_table" --layouts hemi-octahedral --frames 12 --resolution 2048 --view-pixels 256 \
  --pass-cost 3 --out "$OUT/quality_table.md" 2>&1 | tail -3
for t in gpu_tests quality_gpu_tests atlas_outputs_gpu_tests cards_gpu_tests lod_gpu_tests surfels_gpu_tests \
  runtime_gpu_tests runtime_bake_tests; do
  (timeout 120 "$bin/$t" --gtest_brief=1 > "$OUT/$t.txt" 2>&1; echo "== $t exit $?" >> "$OUT/$t.txt") &
  suites+=($!)
done
# Not a bare `wait`: it would also wait for the log's tee, which waits for us.
wait "${suites[@]}"
for t in "$OUT"/*_tests.txt; do grep -E '^== |^\[  (PASSED|FAILED|SKIPPED) ' "$t"; done
