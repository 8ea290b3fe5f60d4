#!/usr/bin/env bash
# The Debian packages end to end, on this machine (needs root and apt-get:
# the CI container; exits 77 = skipped otherwise):
#  1. builds the packages from the already built tree (impostor_packages:
#     no recompilation) and installs them with `apt-get install ./...deb`;
#  2. checks the system user, /var/lib/impostor, /etc/impostor, man pages,
#     and the shared libraries: in their own runtime package (libimpostorX.Y:
#     the versioned files, a shlibs file, ldconfig knows them) that the CLI
#     and libimpostor-dev depend on, -dev holding only the .so links;
#  3. starts impostor-server and one impostor-worker with the ExecStart lines
#     of their installed systemd units and the same environment files (no
#     systemd in a container), as the impostor user, on a free port;
#  4. bakes a real asset through them with the packaged CLI, and builds the
#     stand-alone SDK example against the packaged libimpostor-dev;
#  5. `apt-get remove` (and purge) leaves /var/lib/impostor and its data alone.
#
#   bash deploy/package-test.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
BUILD_DIR=$(cd "${1:-${BUILD_DIR:-build}}" && pwd)
MODEL=${MODEL:-$ROOT/../shared/assets/props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb}
# The runtime library package is named after the SONAME, libimpostor.so.X.Y
# (X.Y: the project's major.minor version).
project_version=$(sed -n 's/^CMAKE_PROJECT_VERSION:STATIC=//p' "$BUILD_DIR/CMakeCache.txt")
LIB_PACKAGE=libimpostor${project_version%.*}
PACKAGES=(impostor-server impostor-worker impostor-cli "$LIB_PACKAGE" libimpostor-dev)

if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null; then
  echo "package-test: needs root and apt-get; skipped"
  exit 77
fi
# Another apt run on the machine: wait for its lock rather than fail.
APT_LOCK=(-o DPkg::Lock::Timeout=600)
fail() { echo "package-test: FAILED: $*" >&2; exit 1; }

WORK=$(mktemp -d /tmp/impostor-package-test.XXXXXX)
SERVER_PID=""
WORKER_PID=""
cleanup() {
  for pid in $WORKER_PID $SERVER_PID; do kill "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$WORK"
}
trap cleanup EXIT

echo "== Building the packages from $BUILD_DIR"
cmake --build "$BUILD_DIR" --target impostor_packages
DEBS=()
for p in "${PACKAGES[@]}"; do
  deb=$(ls "$BUILD_DIR"/packages/"${p}"_*.deb) || fail "no package $p"
  DEBS+=("$deb")
done

echo "== apt-get install ${DEBS[*]}"
apt-get "${APT_LOCK[@]}" install -y --no-install-recommends "${DEBS[@]}"
for p in "${PACKAGES[@]}"; do dpkg -s "$p" >/dev/null || fail "$p not installed"; done

echo "== Files, user and data directory"
getent passwd impostor >/dev/null || fail "no system user impostor"
[ "$(stat -c %U /var/lib/impostor)" = impostor ] || fail "/var/lib/impostor is not owned by impostor"
for f in /etc/impostor/server.conf /etc/impostor/worker.conf /lib/systemd/system/impostor-server.service \
    /lib/systemd/system/impostor-worker@.service /usr/share/man/man1/impostor-server.1 \
    /usr/share/man/man1/impostor-worker.1 /usr/share/man/man1/impostor.1 /usr/include/impostor/cache.h \
    /usr/lib/cmake/impostor/impostorConfig.cmake /usr/lib/pkgconfig/impostor.pc; do
  [ -f "$f" ] || fail "missing $f"
done
echo "== The runtime library package $LIB_PACKAGE"
lib_files=$(dpkg -L "$LIB_PACKAGE")
for so in libimpostor libimpostor_runtime; do
  soname=$(objdump -p /usr/lib/$so.so | sed -n 's/^ *SONAME *//p')
  [[ "$soname" == "$so.so.0."* ]] || fail "$so.so: SONAME '$soname'"
  grep -qx "/usr/lib/$soname" <<<"$lib_files" || fail "$LIB_PACKAGE lacks /usr/lib/$soname"
  # Lines are "<TAB>NAME (...) => PATH"; a here-string, not a pipe, so
  # grep -q's early exit cannot fail the pipeline under pipefail.
  grep -qE "^[[:space:]]+${soname//./\\.} " <<<"$(ldconfig -p)" || fail "ldconfig does not know $soname"
  [ "$(dpkg -S "/usr/lib/$so.so" | cut -d: -f1)" = libimpostor-dev ] || fail "$so.so link not in libimpostor-dev"
  if dpkg -L libimpostor-dev | grep -q "/usr/lib/$so.so\.[0-9]"; then fail "libimpostor-dev holds a versioned $so"; fi
  # Debian naming: the package is the SONAME without .so, digits joined.
  [ "$LIB_PACKAGE" = "$(sed 's/\.so\./ /; s/ //' <<<"${soname/_runtime/}")" ] || fail "$LIB_PACKAGE does not match $soname"
done
shlibs=$(dpkg-query --control-show "$LIB_PACKAGE" shlibs)
grep -q "^libimpostor 0\.[0-9]* $LIB_PACKAGE " <<<"$shlibs" || fail "no shlibs line for libimpostor: $shlibs"
for p in impostor-cli libimpostor-dev; do
  dpkg-query -W -f='${Depends}' "$p" | grep -q "$LIB_PACKAGE (= " || fail "$p does not depend on $LIB_PACKAGE"
done
# libcurl is opened with dlopen (client/delivery/curl_library.h): shlibdeps
# cannot see it, so the package names it.
grep -qE "(^|, )libcurl4( |,|$)" <<<"$(dpkg-query -W -f='${Depends}' "$LIB_PACKAGE")" || fail "$LIB_PACKAGE does not depend on libcurl4"
grep -q "ldconfig" <<<"$(dpkg-query --control-show "$LIB_PACKAGE" postinst)" || fail "$LIB_PACKAGE postinst runs no ldconfig"

version=$(/usr/bin/impostor-server --version)
[[ "$version" =~ ^impostor-server\ [0-9]+\.[0-9]+\.[0-9]+\ \(baker\ .+\)$ ]] || fail "--version: $version"

# The command line of a unit: its ExecStart, with its Environment= defaults
# and its EnvironmentFile, run by sh (which expands ${VAR} and splits $VAR
# as systemd does). Extra "NAME=VALUE" arguments override the file (a free
# port instead of the packaged 0.0.0.0:50051).
unit_command() {
  local unit=$1 instance=$2; shift 2
  local exec_start env_defaults env_file
  exec_start=$(sed -n 's/^ExecStart=//p' "$unit")
  env_defaults=$(sed -n 's/^Environment=//p' "$unit")
  env_file=$(sed -n 's/^EnvironmentFile=-\{0,1\}//p' "$unit")
  exec_start=${exec_start//%H/$(hostname)}
  exec_start=${exec_start//%i/$instance}
  printf 'set -a; %s; . %s; %s; set +a; exec %s' "$env_defaults" "$env_file" "$*" "$exec_start"
}

echo "== impostor-server from its unit's command line"
server_cmd=$(unit_command /lib/systemd/system/impostor-server.service "" IMPOSTOR_LISTEN=127.0.0.1:0)
echo "   $server_cmd"
exec 3< <(cd / && exec runuser -u impostor -- /bin/sh -c "$server_cmd" 2>"$WORK/server.log")
SERVER_PID=$!
line=""
read -r -t 60 line <&3 || true
[[ "$line" =~ listening\ on\ 127\.0\.0\.1:([0-9]+) ]] || { cat "$WORK/server.log"; fail "server did not start: '$line'"; }
PORT=${BASH_REMATCH[1]}
grep -q "data=/var/lib/impostor" "$WORK/server.log" || fail "server not on /var/lib/impostor"

echo "== impostor-worker@1 from its unit's command line"
worker_cmd=$(unit_command "/lib/systemd/system/impostor-worker@.service" 1 IMPOSTOR_SERVER=127.0.0.1:$PORT)
echo "   $worker_cmd"
(cd / && exec runuser -u impostor -- /bin/sh -c "$worker_cmd") 2>"$WORK/worker.log" &
WORKER_PID=$!

echo "== Baking $MODEL through them"
/usr/bin/impostor bake "$MODEL" --out "$WORK/out" --server "127.0.0.1:$PORT" --frames 4 --resolution 128 --quiet \
  || { tail -20 "$WORK/server.log" "$WORK/worker.log"; fail "bake"; }
for f in manifest.json albedo_alpha.png normal_depth.png; do
  [ -s "$WORK/out/$f" ] || fail "bake wrote no $f"
done
grep -q '"frames": *4' "$WORK/out/manifest.json" || fail "manifest: not 4 frames"
[ "$(find /var/lib/impostor -type f | wc -l)" -gt 3 ] || fail "nothing stored in /var/lib/impostor"

echo "== The SDK example against the packaged libimpostor-dev"
cmake -S "$ROOT/examples/consumer" -B "$WORK/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
grep -q "impostor_DIR:PATH=/usr/lib/cmake/impostor" "$WORK/consumer/CMakeCache.txt" || fail "not the packaged SDK"
cmake --build "$WORK/consumer" >/dev/null
key=$(sed -n 's/.*"cache_key": *"\([0-9a-f]*\)".*/\1/p' "$WORK/out/manifest.json" | head -1)
[ -n "$key" ] || fail "no cache_key in the manifest"
"$WORK/consumer/fetch_and_pick" "127.0.0.1:$PORT" "$WORK/cache" "$key" > "$WORK/fetch.txt"
grep -q "^key $key downloaded$" "$WORK/fetch.txt" || fail "fetch_and_pick: $(cat "$WORK/fetch.txt")"
albedo_sha=$(sha256sum "$WORK/out/albedo_alpha.png" | cut -d' ' -f1)
grep -q "^file albedo_alpha $albedo_sha " "$WORK/fetch.txt" || fail "fetched albedo differs from the baked one"

kill -TERM "$WORKER_PID" "$SERVER_PID"
wait "$WORKER_PID" "$SERVER_PID" 2>/dev/null || true
WORKER_PID=""
SERVER_PID=""

echo "== apt-get remove, then purge: the data directory stays"
stored_before=$(find /var/lib/impostor -type f | wc -l)
apt-get "${APT_LOCK[@]}" remove -y "${PACKAGES[@]}"
[ ! -e /usr/bin/impostor-server ] || fail "/usr/bin/impostor-server still there after remove"
[ -f /var/lib/impostor/jobs.sqlite3 ] || fail "remove deleted /var/lib/impostor/jobs.sqlite3"
[ "$(find /var/lib/impostor -type f | wc -l)" -eq "$stored_before" ] || fail "remove changed /var/lib/impostor"
[ -f /etc/impostor/server.conf ] || fail "remove deleted a conffile (only purge may)"
# (Only what dpkg still knows: a package without conffiles is gone already.)
mapfile -t known < <(dpkg-query -W -f='${Package}\n' "${PACKAGES[@]}" 2>/dev/null)
apt-get "${APT_LOCK[@]}" purge -y "${known[@]}"
[ ! -e /etc/impostor/server.conf ] || fail "purge left /etc/impostor/server.conf"
[ "$(find /var/lib/impostor -type f | wc -l)" -eq "$stored_before" ] || fail "purge changed /var/lib/impostor"
echo "package-test: OK (packages installed, unit command lines served a bake, data kept on remove and purge)"
