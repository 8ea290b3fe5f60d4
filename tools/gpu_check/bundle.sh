#!/bin/bash
# Builds a bundle that checks the worker on a GPU host without installing
# anything there but the bundle (tools/gpu_check/README.md):
#
#   bash tools/gpu_check/bundle.sh [BUILD_DIR] [OUT_DIR] [e2e]
#
# e2e: only the asset the end-to-end step bakes (DamagedHelmet), for
# `run.sh e2e`: 29 MB instead of 57.
#
# OUT_DIR (default /tmp/gpu_check) gets pack.tar.xz (binaries + libraries,
# pack.py), assets.tar (the test assets the GPU suites read), glvnd/ (the GL
# vendor-neutral dispatch libraries NVIDIA's Vulkan driver loads), paths.env
# (where the binaries expect their build and asset folders) and run.sh.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=$(cd "${1:-$here/../../build}" && pwd)
out=${2:-/tmp/gpu_check}
only=${3:-all}
assets=$(sed -n 's/^IMPOSTOR_ASSETS_DIR:PATH=//p' "$build/CMakeCache.txt")
assets=$(cd "$assets" && pwd)
binaries="bake_bench bake_stages png_bench metrics_bench quality_table impostor impostor-server impostor-worker gpu_tests quality_gpu_tests
  atlas_outputs_gpu_tests cards_gpu_tests lod_gpu_tests surfels_gpu_tests runtime_gpu_tests runtime_bake_tests
  isolated_load_bench fleet_bench"
# The end-to-end and fleet benches also run nginx and curl (Debian's, packed
# with their libraries: a GPU host may have neither).
tools="$(command -v nginx || echo /usr/sbin/nginx) $(command -v curl)"
rm -rf "$out" && mkdir -p "$out/glvnd"
out=$(cd "$out" && pwd)  # the asset step below runs from another folder
python3 "$here/pack.py" "$out/pack" $(for b in $binaries; do echo "$build/bin/$b"; done) $tools
for lib in libGLdispatch.so.0 libGLX.so.0 libEGL.so.1 libOpenGL.so.0; do
  cp -L "$(ldconfig -p | awk -v l="$lib" '$1 == l && /x86-64/ {print $NF; exit}')" "$out/glvnd/"
done
(cd "$out" && tar cf - pack | xz -6 -T0 > pack.tar.xz && rm -rf pack)
# The assets the suites and benches name (tests/ and bench/ sources).
if [ "$only" = e2e ]; then
  (cd "$assets" && tar cf "$out/assets.tar" props_pbr/DamagedHelmet)
else
  (cd "$assets" && tar cf "$out/assets.tar" --exclude=edge_cases/khronos/AnisotropyBarnLamp \
    MANIFEST.md props_pbr vegetation/AlphaBlendModeTest vegetation/StylizedTree_ChrisCLP \
    vegetation/Quaternius_CommonTree_1 vegetation/TreeLowPoly_RicardoSanchez vegetation/GlassVaseFlowers \
    highpoly/TransmissionTest \
    edge_cases/khronos edge_cases/missing_textures/BoxTextured_png_removed)
fi
# The commit the binaries come from, for the benches' headers (plus a mark
# when sources differ from it).
commit=$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo "?")
[ -n "$(git -C "$here" status --porcelain --untracked-files=no -- server worker client common proto 2>/dev/null)" ] &&
  commit="$commit + uncommitted sources"
printf 'BUILD_BIN=%q\nASSETS_DIR=%q\nCOMMIT=%q\n' "$build/bin" "$assets" "$commit" > "$out/paths.env"
cp "$here/run.sh" "$out/"
# bench/e2e_bench.sh and its Python, run from the bundle (run.sh's e2e step).
mkdir -p "$out/bench"
cp "$here/../../bench/e2e_bench.sh" "$here/../../bench/e2e_bench.py" "$here/../../bench/e2e_blender.py" \
  "$here/../../bench/e2e_errors.py" "$here/../../bench/e2e_fetch.py" "$here/../../bench/e2e_util.py" "$out/bench/"
du -sh "$out"
