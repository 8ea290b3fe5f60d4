#!/usr/bin/env bash
# Fetch speed against a static file server (issue 18): runs cache_bench with
# nginx serving the same result files, so `impostor fetch` and Cache::Get
# print as ratios to curl's time in one run. Installs Debian's nginx-light
# when missing (bench only: CI's deploy/install-deps.sh does not need it).
#   bash bench/fetch_bench.sh [BUILD_DIR] [--downloads N]
set -euo pipefail
build="${1:-build}"
shift || true
nginx="$(command -v nginx || true)"
[[ -z "$nginx" && -x /usr/sbin/nginx ]] && nginx=/usr/sbin/nginx
if [[ -z "$nginx" ]]; then
  echo "installing nginx-light (bench only)" >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends nginx-light >/dev/null
  nginx=/usr/sbin/nginx
fi
command -v curl >/dev/null || { echo "fetch_bench: curl is needed" >&2; exit 2; }
exec "$build/bin/cache_bench" --hits 100 --nginx "$nginx" "$@"
