#!/bin/sh
# compare_blender.sh: the "30x Blender Cycles" claim (issues 18 and 45),
# reproducible, against what a user waits for: `impostor bake ASSET --layout
# hemi-octahedral --frames 12 --resolution 2048` through a real farm (the
# CLI, impostor-server with one local worker), warm, as bench/e2e_bench.sh
# measures it; then Debian's Blender (blender -b, Cycles on the CPU, 16
# samples, orthographic cameras framing the bounding sphere, each view at the
# bake's render size: tile x supersampling) renders the very same 144 views
# of the last warm bake's manifest in the same run. Prints e2e_bench's table
# with two more rows: Blender's time and Blender / end to end (warm), target
# >= 30. Exits 0 without a comparison when Blender is not installed (Debian
# package `blender`).
#
#   bench/compare_blender.sh [BUILD_DIR] [ASSET.glb]
#   BLENDER_VIEWS=12 bench/compare_blender.sh   # Blender renders 12 of the
#       views, spread evenly, and the ratio extrapolates its per-view time to
#       all of them (said so in the output): minutes instead of many.
#   WARM=N: warm bakes (default 3; the median is compared).
#
# Until 2026-12-03 this compared Blender with one cold bake by
# bench/bake_bench (octahedral, no CLI); the issue's figure is the CLI's warm
# bake. Figures on a shared machine are noisy: the ratio is what counts, and
# both halves run back to back on the same machine (Blender's own time has
# ranged 145-378 s between runs here).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-"$here/../build"}
if ! command -v blender >/dev/null 2>&1; then
  echo "compare_blender: blender is not installed (apt-get install blender); nothing compared"
  exit 0
fi
if [ -n "${2:-}" ]; then
  MODEL=$2
  export MODEL
fi
exec bash "$here/e2e_bench.sh" "$build" --warm "${WARM:-3}" --fetch-pairs 0 --batch-assets 0 \
  --blender --blender-views "${BLENDER_VIEWS:-0}"
