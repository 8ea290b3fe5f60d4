#!/bin/sh
# compare_blender.sh: issue 18's "30x Blender Cycles" claim, reproducible.
# Bakes ASSET (DamagedHelmet by default) 12 x 12 octahedral at 2048 px with
# bench/bake_bench (a real server and worker, end to end), then renders the
# very same 144 views with Debian's Blender (blender -b, Cycles on the CPU,
# 16 samples, orthographic cameras framing the bounding sphere, each view at
# the bake's render size: tile x supersampling) in the same run, and prints
# both times and their ratio. Exits 0 without a comparison when Blender is
# not installed (Debian package `blender`).
#
#   bench/compare_blender.sh [BUILD_DIR] [ASSET.glb]
#   BLENDER_VIEWS=12 bench/compare_blender.sh   # Blender renders 12 of the
#       views, spread evenly, and the ratio extrapolates its per-view time to
#       all of them (said so in the output): minutes instead of an hour.
#
# Figures on a shared machine are noisy: the ratio is what counts, and both
# halves run back to back on the same machine.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-"$here/../build"}
asset=${2:-"$here/../../shared/assets/props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb"}
samples=16
if ! command -v blender >/dev/null 2>&1; then
  echo "compare_blender: blender is not installed (apt-get install blender); nothing compared"
  exit 0
fi
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

"$build/bin/bake_bench" --fetches 1 --keep-result "$scratch/result" "$asset" | tee "$scratch/bake.txt"
# The asset's row: wall_s is the third column.
bake_wall=$(awk '$2 ~ /^[0-9]+$/ && NF >= 14 { print $3 }' "$scratch/bake.txt" | tail -n 1)
[ -n "$bake_wall" ] || { echo "compare_blender: bake_bench printed no result row" >&2; exit 1; }
# Each view at the size the bake rendered it: tile_size x supersampling.
manifest="$scratch/result/manifest.json"
pixels=$(python3 -c 'import json,sys; m=json.load(open(sys.argv[1])); print(m["tile_size"] * m.get("supersampling", 2))' \
  "$manifest")
views=$(python3 -c 'import json,sys; print(len(json.load(open(sys.argv[1]))["views"]))' "$manifest")
mkdir -p "$scratch/blender"
start=$(date +%s.%N)
limit=${BLENDER_VIEWS:-0}
blender -b --factory-startup --python-exit-code 1 --python "$here/blender_views.py" -- \
  "$asset" "$manifest" "$pixels" "$samples" "$scratch/blender" "$limit" >"$scratch/blender.log" 2>&1 ||
  { tail -n 20 "$scratch/blender.log" >&2; echo "compare_blender: blender failed" >&2; exit 1; }
end=$(date +%s.%N)
grep '^blender_views:' "$scratch/blender.log"
rendered=$(find "$scratch/blender" -name 'view_*.png' | wc -l)
expected=$views
if [ "$limit" -gt 0 ] && [ "$limit" -lt "$views" ]; then expected=$limit; fi
[ "$rendered" -eq "$expected" ] || { echo "compare_blender: blender wrote $rendered of $expected views" >&2; exit 1; }
render_s=$(sed -n 's/^blender_views: .* render_s \([0-9.]*\)$/\1/p' "$scratch/blender.log")
python3 - "$bake_wall" "$start" "$end" "$views" "$pixels" "$samples" "$rendered" "$render_s" <<'PY'
import sys
bake, start, end = float(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
views, pixels, samples = int(sys.argv[4]), sys.argv[5], sys.argv[6]
rendered, render_s = int(sys.argv[7]), float(sys.argv[8])
blender = end - start
if rendered < views:
    # Process start and import as measured, the renders scaled to every view.
    blender = blender - render_s + render_s * views / rendered
    how = f"extrapolated from {rendered} of {views} views ({render_s / rendered:.2f} s a view)"
else:
    how = "process start to exit"
print(f"compare_blender: {views} views at {pixels} px: impostor bake {bake:.2f} s end to end (maps, quality pass), "
      f"Blender 3.4 Cycles CPU {samples} samples {blender:.2f} s ({how}): "
      f"{blender / bake:.1f}x (target >= 30x)")
PY
