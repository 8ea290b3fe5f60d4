#!/usr/bin/env bash
# Regenerates the reference pages that come from the code:
#   docs/reference/cli.md, server-flags.md, worker-flags.md  from the binaries' --help
#   docs/reference/grpc-api.md                               from proto/impostor/v1/*.proto
#
#   bash tools/docs/gen_reference.sh [BIN_DIR [OUT_DIR]]
#
# BIN_DIR defaults to build/bin (build the three programs first:
# `bash deploy/build.sh impostor-server impostor-worker impostor`), OUT_DIR to
# docs/reference. Run it after changing a flag, a command's help or a proto
# comment, and commit the pages it rewrites; the CTest `docs_site` fails while
# they differ from what the binaries print.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
bin_dir="${1:-$root/build/bin}"
out_dir="${2:-$root/docs/reference}"
python3 "$root/tools/docs/gen_cli_reference.py" --bin-dir "$bin_dir" --out-dir "$out_dir"
python3 "$root/tools/docs/gen_grpc_reference.py" --out "$out_dir/grpc-api.md"
