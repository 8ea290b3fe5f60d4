#!/usr/bin/env bash
# One command from a fresh Debian 12 machine to a passing test suite:
# installs the dependencies, builds, runs every CTest suite (unit,
# integration, gpu — the GPU suites run on Mesa lavapipe when there is no GPU).
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
bash deploy/build.sh
BUILD_DIR=${BUILD_DIR:-build}
cd "$BUILD_DIR"
ctest --output-on-failure --timeout 900 -j 2 -LE 'soak|packaging'
# The Debian packages: built from this tree, installed with apt-get, a bake
# through the unit's command line, then removed (deploy/package-test.sh).
ctest --output-on-failure -L packaging
# The bounded chaos soak (about 5 minutes) last, alone, with both cores.
ctest --output-on-failure --timeout 900 -L soak
cd - >/dev/null
# The glTF loader under libFuzzer with ASan+UBSan: a fixed, seeded number of runs (fuzz/run.sh).
bash fuzz/run.sh
