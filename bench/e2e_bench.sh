#!/usr/bin/env bash
# End to end against in process, in one run (issue 45): what a user waits for
# when the CLI bakes through a real farm, beside what the same bake costs in
# process, and where the difference goes.
#
#   bash bench/e2e_bench.sh [BUILD_DIR] [--warm N] [--fetch-pairs N] [--fetch-only] [--batch-assets N]
#                           [--blender [--blender-views N]]
#
# 1. Starts build/bin/impostor-server with one local worker on free loopback
#    ports and a temporary data directory (as deploy/quickstart.sh does, plus
#    an HTTP port for /metrics), then times `impostor bake DamagedHelmet.glb
#    --layout hemi-octahedral --frames 12 --resolution 2048`: the first
#    (cold) bake right after the server listens, then N (default 3) warm
#    bakes of the same request on the same farm. Before each warm bake the
#    result is purged (`impostor admin purge`, blobs included), so every warm
#    bake really bakes and uploads its maps; why purge rather than change the
#    cache key: Bench.purge in bench/e2e_bench.py.
# 2. Interleaved with the warm bakes, N in-process bakes of the same request
#    (build/bin/bake_stages, the second bake of each process) and the ratio
#    end to end / in process (issue target <= 1.15).
# 3. build/bin/isolated_load_bench on the same asset (target <= 1.15).
# 4. `impostor fetch KEY --out DIR` of the result just baked against nginx +
#    curl serving exactly the same files on one connection, alternating
#    rounds (default 7; the order rotates), and `impostor cache get KEY`
#    (Cache::Get into a fresh cache directory) and the same curl against
#    the farm's own HTTP front end (/api/v1/results/KEY/files/NAME) in the
#    same rounds, and `impostor fetch` and `cache get` again with
#    --farm-http (the result's large files from the farm's HTTP front end;
#    bench/e2e_fetch.py), and the Python client's Client.fetch over gRPC and
#    with farm_http when build/python holds it (bench/e2e_pyfetch.py: the
#    fetch alone, and its process); medians and the ratios (target <= 1.25); and
#    `impostor --version` against `curl --version`, 20 of each alternated
#    (what every CLI run pays before its first byte). Installs
#    Debian's nginx-light when no nginx is found, as bench/fetch_bench.sh.
#    Then a batch (--batch-assets N, default 13; 0 skips it): `impostor
#    bake-batch` bakes the same model at N frame counts (256 px, 39 files
#    each: 507 files for 13), then, every request a cache hit, bake-batch
#    into a fresh folder against curl fetching the same files from nginx in
#    one process, alternating rounds (and bake-batch --farm-http): what a CI
#    job re-running a batch pays over a plain download.
# 5. The farm's own /metrics stage sums over the warm bakes beside
#    bake_stages' stages.
# --fetch-only: the cold bake (for a result to fetch) and step 4 alone;
# --fetch-pairs 0 skips step 4.
# --blender (bench/compare_blender.sh runs this): after the warm bakes,
# Blender 3.4 Cycles (CPU, 16 samples) renders the last warm bake's own views
# at the bake's pixels (bench/blender_views.py), timed from process start to
# exit, and the table gains Blender / end to end (warm), issue 45's "30x
# Blender" figure. --blender-views N renders N of them and scales the render
# time to all (a quick estimate; the process start and import as measured).
# Ends with a markdown table of every figure. A bench, not a test: nothing is
# asserted, but a step that fails stops it with a message and exit status 1.
# Everything lives under one mktemp -d, removed (and the server, its worker
# and nginx stopped) by the trap on exit; the binaries are copied there first,
# so a rebuild in BUILD_DIR during the run cannot mix two versions.
# MODEL=path.glb bakes another asset.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)

die() { echo "e2e_bench: $*" >&2; exit 1; }
usage() { echo "usage: bash bench/e2e_bench.sh [BUILD_DIR] [--warm N] [--fetch-pairs N] [--fetch-only] [--batch-assets N] [--blender [--blender-views N]]" >&2; exit 2; }

build=$root/build
warm=3
pairs=7
fetch_only=()
batch=13
blender=()
blender_views=0
while [[ $# -gt 0 ]]; do
  case "$1" in
    --warm) [[ $# -ge 2 ]] || usage; warm=$2; shift 2 ;;
    --warm=*) warm=${1#*=}; shift ;;
    --fetch-pairs) [[ $# -ge 2 ]] || usage; pairs=$2; shift 2 ;;
    --fetch-pairs=*) pairs=${1#*=}; shift ;;
    --fetch-only) fetch_only=(--fetch-only); shift ;;
    --batch-assets) [[ $# -ge 2 ]] || usage; batch=$2; shift 2 ;;
    --batch-assets=*) batch=${1#*=}; shift ;;
    --blender) blender=(--blender); shift ;;
    --blender-views) [[ $# -ge 2 ]] || usage; blender_views=$2; shift 2 ;;
    --blender-views=*) blender_views=${1#*=}; shift ;;
    -h|--help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"; exit 0 ;;
    -*) echo "e2e_bench: unknown flag $1" >&2; usage ;;
    *) build=$1; shift ;;
  esac
done
[[ "$warm" =~ ^[1-9][0-9]*$ ]] || die "--warm: '$warm' is not a positive number"
[[ "$pairs" =~ ^[0-9]+$ ]] || die "--fetch-pairs: '$pairs' is not a number"
[[ "$pairs" -gt 0 || ${#fetch_only[@]} -eq 0 ]] || die "--fetch-only needs --fetch-pairs of at least 1"
[[ "$blender_views" =~ ^[0-9]+$ ]] || die "--blender-views: '$blender_views' is not a number"
if [[ ${#blender[@]} -gt 0 ]]; then
  command -v blender >/dev/null || die "--blender: blender is not installed (apt-get install blender)"
fi
[[ "$batch" =~ ^[0-9]+$ && "$batch" -le 28 ]] || die "--batch-assets: '$batch' is not a number in 0..28 (frames 4..31 at 256 px)"
[[ -d "$build" ]] || die "no build directory $build"
build=$(cd "$build" && pwd)

model=${MODEL:-$root/../shared/assets/props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb}
[[ -f "$model" ]] || die "the asset $model is missing (the shared assets belong in ../shared/assets)"
for b in impostor-server impostor-worker impostor bake_stages isolated_load_bench; do
  [[ -x "$build/bin/$b" ]] || die "$build/bin/$b is missing: build it (cmake --build $build --target $b)"
done
command -v python3 >/dev/null || die "python3 is needed"
command -v curl >/dev/null || die "curl is needed"
nginx="$(command -v nginx || true)"
[[ -z "$nginx" && -x /usr/sbin/nginx ]] && nginx=/usr/sbin/nginx
if [[ -z "$nginx" ]]; then
  echo "installing nginx-light (bench only)" >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends nginx-light >/dev/null ||
    die "nginx is missing and apt-get could not install nginx-light"
  nginx=/usr/sbin/nginx
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/e2e_bench.XXXXXX")
# Stops what the bench started (WORK/pids/NAME holds each pid: the bench
# itself, then the server, so it drains its worker, then whatever is left),
# then removes WORK.
# shellcheck disable=SC2317  # alive and cleanup run from the trap
# Running: the pid exists and is not a zombie (an orphan waits for init).
alive() { local st; st=$(sed 's/^.*) //' "/proc/$1/stat" 2>/dev/null) && [[ ${st:0:1} != Z ]]; }
# shellcheck disable=SC2317
cleanup() {
  local rc=$? f pid
  for f in python blender server worker nginx; do
    [[ -f "$work/pids/$f" ]] || continue
    pid=$(cat "$work/pids/$f")
    [[ "$pid" =~ ^[0-9]+$ ]] || continue
    if [[ $f == nginx ]]; then kill -QUIT "$pid" 2>/dev/null || true; else kill -TERM "$pid" 2>/dev/null || true; fi
    for _ in $(seq 1 100); do alive "$pid" || break; sleep 0.1; done
    if alive "$pid"; then kill -KILL "$pid" 2>/dev/null || true; fi
  done
  rm -rf "$work"
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
# The run uses copies of the binaries, so a rebuild in $build/bin while it
# runs (a shared build directory) cannot mix two versions in one table.
mkdir "$work/bin" "$work/pids"
for b in impostor-server impostor-worker impostor bake_stages isolated_load_bench; do
  cp -p "$build/bin/$b" "$work/bin/$b"
done
# The Python client, when built (bench/e2e_pyfetch.py times its fetch).
if [[ -d "$build/python/impostor" ]]; then cp -rp "$build/python" "$work/python"; fi
newest=$(stat -c '%y' "$work"/bin/* | cut -c1-19 | sort | tail -n 1)
echo "e2e_bench: binaries copied from $build/bin (the newest built $newest)"

# In the background so that a signal reaches the trap at once (bash runs
# traps only between commands, and `wait` is one it interrupts).
python3 "$root/bench/e2e_bench.py" --build "$work" --work "$work" --model "$model" --nginx "$nginx" \
  --warm "$warm" --fetch-pairs "$pairs" --batch-assets "$batch" "${fetch_only[@]}" "${blender[@]}" \
  --blender-views "$blender_views" &
echo $! > "$work/pids/python"
status=0
wait $! || status=$?
rm -f "$work/pids/python"  # reaped: its pid is no longer ours to signal
exit "$status"
