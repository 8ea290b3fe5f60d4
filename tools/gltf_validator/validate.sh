#!/usr/bin/env bash
# Runs the Khronos glTF validator (npm gltf-validator, pinned in
# package.json) on one file; see validate.mjs for output and exit status.
# Installs the pinned package on first use when deploy/install-deps.sh has
# not already done so.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
if [[ ! -d "$here/node_modules/gltf-validator" ]]; then
  (cd "$here" && npm ci --no-audit --no-fund --loglevel=error >&2)
fi
exec node "$here/validate.mjs" "$@"
