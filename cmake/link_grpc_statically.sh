#!/usr/bin/env bash
# Link launcher for the `impostor` CLI (RULE_LAUNCH_LINK; client/CMakeLists.txt):
# runs the link command it is given with gRPC, protobuf, Abseil and their
# helpers taken from Debian's static archives instead of their shared objects.
#
# Why: a CLI run is short, and on start the dynamic loader maps and relocates
# every shared object the binary needs: 60 for the CLI, 55 of them gRPC's
# stack (a gRPC library, protobuf, c-ares, re2, upb and 40 Abseil ones). On
# the 2-core development VM `impostor --version` took 22.3 ms of CPU and 754
# page faults, curl's 21 ms; linked this way, 11.3 ms and 426 (perf stat -r 30),
# and a fetch of a 26 MB result about 17 ms less. A CI job runs the CLI for
# every asset. OpenSSL, zlib, spdlog, fmt and the C and C++ runtimes stay
# shared (OpenSSL's security updates reach the CLI without a rebuild).
#
# All or nothing: the archives replace the shared objects only when every one
# of them has its archive; otherwise the command runs unchanged (one copy of
# Abseil loaded twice, static and shared, would be two sets of its globals).
set -euo pipefail

# Libraries of gRPC's stack, by the file name's stem.
static_stem() {
  case "$1" in
    grpc | grpc++ | gpr | upb | address_sorting | protobuf | cares | re2 | yaml-cpp | absl_*) return 0 ;;
    *) return 1 ;;
  esac
}

args=()
archives=()
for arg in "$@"; do
  stem=""
  dir=""
  if [[ "$arg" =~ ^(/.+)/lib([^/]+)\.so(\.[0-9.]+)?$ ]]; then
    dir="${BASH_REMATCH[1]}"
    stem="${BASH_REMATCH[2]}"
  elif [[ "$arg" =~ ^-l(.+)$ ]]; then
    stem="${BASH_REMATCH[1]}"
    dir="/usr/lib/$(gcc -print-multiarch 2>/dev/null || echo x86_64-linux-gnu)"
  fi
  if [[ -n "$stem" ]] && static_stem "$stem"; then
    if [[ ! -f "$dir/lib$stem.a" ]]; then
      echo "link_grpc_statically: no $dir/lib$stem.a; linking shared" >&2
      exec "$@"
    fi
    archives+=("$dir/lib$stem.a")
  else
    args+=("$arg")
  fi
done
if [[ ${#archives[@]} -eq 0 ]]; then exec "$@"; fi
# A group: the archives refer to each other in every direction. Then what
# they need of the shared system libraries.
exec "${args[@]}" -Wl,--start-group "${archives[@]}" -Wl,--end-group -lssl -lcrypto -lz -lpthread -ldl
