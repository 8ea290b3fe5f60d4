#!/usr/bin/env bash
# One command from a fresh Debian 12 machine to a baked impostor:
# installs the dependencies, builds, starts impostor-server with local
# workers on localhost:50051, bakes a real asset from ../shared/assets with
# the CLI, bakes it again (answered from the cache), prints where the atlas
# is, and stops the server.
#
#   bash deploy/quickstart.sh [MODEL] [extra `impostor bake` flags...]
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
MODEL=${1:-../shared/assets/props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb}
shift || true
PORT=${PORT:-50051}
BUILD_DIR=${BUILD_DIR:-build}
DATA_DIR=${DATA_DIR:-$ROOT/out/farm-data}
OUT_DIR=${OUT_DIR:-$ROOT/out/$(basename "${MODEL%.*}")}

bash deploy/install-deps.sh
# Only the three programs it runs, not the test suites.
bash deploy/build.sh impostor-server impostor-worker impostor
BIN=$ROOT/$BUILD_DIR/bin

mkdir -p "$DATA_DIR"
"$BIN/impostor-server" --listen "127.0.0.1:$PORT" --data "$DATA_DIR" --local-workers 2 \
  > "$ROOT/out/server.log" 2>&1 &
SERVER_PID=$!
trap 'kill $SERVER_PID 2>/dev/null; wait $SERVER_PID 2>/dev/null || true' EXIT
# Wait for the health check rather than for a fixed time.
for _ in $(seq 1 100); do
  if grep -q "listening on" "$ROOT/out/server.log" 2>/dev/null; then break; fi
  if ! kill -0 $SERVER_PID 2>/dev/null; then cat "$ROOT/out/server.log"; exit 1; fi
  sleep 0.1
done

echo "== Baking $MODEL (octahedral, 12x12 frames, 2048 px)"
"$BIN/impostor" bake "$MODEL" --out "$OUT_DIR" --server "127.0.0.1:$PORT" "$@"
echo
echo "== Same request again: answered from the cache"
time "$BIN/impostor" bake "$MODEL" --out "$OUT_DIR" --server "127.0.0.1:$PORT" "$@"
echo
echo "Atlas maps and manifest: $OUT_DIR"
ls -l "$OUT_DIR"
