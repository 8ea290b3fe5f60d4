#!/usr/bin/env bash
# One command from a fresh Debian 12 machine to a passing test suite:
# installs the dependencies, builds, runs every CTest suite (unit,
# integration, gpu — the GPU suites run on Mesa lavapipe when there is no GPU).
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
bash deploy/build.sh
BUILD_DIR=${BUILD_DIR:-build}
# What the temporary directory holds before the tests: a green run adds
# nothing to it (checked at the end; a failing test keeps its files and
# names them, which is why this runs only after every suite passed).
tmp_root=${TMPDIR:-/tmp}
tmp_before="$BUILD_DIR/tmp-before-tests.txt"
ls -A "$tmp_root" | sort > "$tmp_before"
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
# Left behind by this run: every entry of the temporary directory that was
# not there before, but the X server's socket folders (Godot's Xvfb).
leftovers=$(ls -A "$tmp_root" | sort | comm -13 "$tmp_before" - |
  grep -vxE '\.(X11|ICE|XIM|font|Test)-unix' || true)
if [ -n "$leftovers" ]; then
  echo "deploy/test.sh: the tests passed but left these in $tmp_root:" >&2
  echo "$leftovers" | sed 's/^/  /' >&2
  exit 1
fi
echo "deploy/test.sh: nothing left in $tmp_root"
