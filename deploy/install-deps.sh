#!/usr/bin/env bash
# Installs every build and run dependency of the impostor bake farm from
# Debian 12 packages. Used by .ci/run and by the README's commands; safe to
# run again (apt-get skips what is already there).
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

packages=(
  build-essential cmake ninja-build pkg-config git
  # RPC
  libgrpc++-dev libgrpc-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  # Rendering: Vulkan loader + headers, lavapipe (CPU Vulkan), glslang
  libvulkan-dev mesa-vulkan-drivers vulkan-tools glslang-tools
  # Assets and images
  libtinygltf-dev libstb-dev nlohmann-json3-dev libopenimageio-dev libglm-dev libmeshoptimizer-dev
  # Infrastructure
  libspdlog-dev libfmt-dev libabsl-dev libssl-dev libsqlite3-dev
  # Tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # Fuzzing (fuzz/run.sh): clang with libFuzzer, ASan and UBSan runtimes
  clang-14 libclang-rt-14-dev
)

export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${packages[@]}"
