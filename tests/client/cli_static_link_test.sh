#!/usr/bin/env bash
# The CLI's link (cmake/link_grpc_statically.sh, client/CMakeLists.txt):
#   1. the built `impostor` needs none of gRPC's shared stack, and still
#      needs OpenSSL shared (the option is on: CTest passes "static");
#   2. the launcher swaps a stack library for its archive, keeps every other
#      argument in place, and groups the archives at the end;
#   3. all or nothing: one library without an archive and the command runs
#      exactly as given.
#
#   cli_static_link_test.sh IMPOSTOR_BINARY LAUNCHER static|shared
set -euo pipefail
cli="$1"
launcher="$2"
mode="$3"
fail() {
  echo "FAIL: $*" >&2
  exit 1
}

needed="$(readelf -d "$cli" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')"
[[ -n "$needed" ]] || fail "readelf found no NEEDED entries in $cli"
if [[ "$mode" == "static" ]]; then
  if grep -E '^lib(grpc|gpr|protobuf|absl_|upb|cares|re2|yaml-cpp)' <<<"$needed"; then
    fail "$cli still needs the shared libraries above"
  fi
  grep -q '^libssl\.so' <<<"$needed" || fail "$cli does not need libssl shared: $needed"
fi
"$cli" --version >/dev/null || fail "$cli --version failed"

libdir="$(mktemp -d)"
trap 'rm -rf "$libdir"' EXIT
touch "$libdir/libgrpc.so.29.0.0" "$libdir/libgrpc.a" "$libdir/libabsl_base.so.20220623.0.0" "$libdir/libabsl_base.a"
touch "$libdir/libspdlog.so.1.10.0" "$libdir/libprotobuf.so"

# `echo` as the linker: the launcher's command line comes back as text.
out="$(bash "$launcher" echo -O2 main.o "$libdir/libgrpc.so.29.0.0" "$libdir/libspdlog.so.1.10.0" \
  "$libdir/libabsl_base.so.20220623.0.0" -lm)"
want="-O2 main.o $libdir/libspdlog.so.1.10.0 -lm -Wl,--start-group $libdir/libgrpc.a $libdir/libabsl_base.a -Wl,--end-group -lssl -lcrypto -lz -lpthread -ldl"
[[ "$out" == "$want" ]] || fail "launcher gave: $out
want: $want"

# libprotobuf.a is missing: nothing is swapped.
out="$(bash "$launcher" echo main.o "$libdir/libgrpc.so.29.0.0" "$libdir/libprotobuf.so" 2>/dev/null)"
want="main.o $libdir/libgrpc.so.29.0.0 $libdir/libprotobuf.so"
[[ "$out" == "$want" ]] || fail "with an archive missing the launcher gave: $out
want: $want"
echo "ok"
