#!/usr/bin/env bash
# The documentation's own test (CTest `docs_site`, label unit):
#   1. README.md is the front door, not the manual: at most 250 lines, and
#      every file it links to exists;
#   2. the site builds with `mkdocs build --strict` (no broken link or anchor,
#      no missing include) into a temporary folder, removed afterwards, and
#      every page under docs/ is in the nav (no orphan page);
#   3. the generated reference is what the code says today: the gRPC page is
#      rendered again from the protos and the CLI pages from the binaries'
#      --help, into a temporary folder, and compared with docs/reference/
#      (without built binaries that part is skipped, saying so);
#   4. the tutorials' runner markers (<!-- tutorial: ... -->) are well formed
#      (tools/docs/run_tutorials.py --list; CTest docs_tutorials runs them).
#
#   bash tools/docs/check_site.sh [BIN_DIR]      (default build/bin)
set -uo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
bin_dir="${1:-$root/build/bin}"
cd "$root"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
failed=0
fail() { echo "docs_site: FAIL: $*" >&2; failed=1; }

# 1. README
max_lines=250
lines=$(wc -l < README.md)
if [ "$lines" -gt "$max_lines" ]; then
  fail "README.md has $lines lines, more than $max_lines: move the detail into a page under docs/ and link it"
else
  echo "docs_site: README.md has $lines lines (at most $max_lines)"
fi
optional=$(python3 - <<'PY'
import re
text = open("mkdocs.yml", encoding="utf-8").read()
m = re.search(r"^  optional_pages:\n((?:    - .*\n)+)", text, re.M)
print("\n".join("docs/" + l.strip()[2:].strip() for l in m.group(1).splitlines()) if m else "")
PY
)
while IFS= read -r target; do
  path="${target%%#*}"
  [ -z "$path" ] && continue
  case "$path" in http:*|https:*|mailto:*) continue ;; esac
  if [ ! -e "$path" ]; then
    if grep -qxF "$path" <<<"$optional"; then
      echo "docs_site: README links to $path, which is not written yet (optional_pages in mkdocs.yml)"
    else
      fail "README.md links to $target, which does not exist"
    fi
  fi
done < <(grep -o '\](\([^)]*\))' README.md | sed 's/^](\(.*\))$/\1/' | sort -u)

# 2. The site
if ! command -v mkdocs >/dev/null 2>&1; then
  fail "mkdocs is not installed (Debian: apt-get install mkdocs mkdocs-material; deploy/install-deps.sh does it)"
else
  if PYTHONWARNINGS=ignore::DeprecationWarning mkdocs build --strict --site-dir "$tmp/site" >"$tmp/mkdocs.log" 2>&1; then
    echo "docs_site: mkdocs build --strict: ok"
  else
    sed 's/\x1b\[[0-9;]*m//g' "$tmp/mkdocs.log" >&2
    fail "mkdocs build --strict failed (above)"
  fi
  if grep -q 'but are not included in the "nav" configuration' "$tmp/mkdocs.log"; then
    sed -n '/but are not included in the "nav"/,/^[A-Z]/p' "$tmp/mkdocs.log" | sed 's/\x1b\[[0-9;]*m//g' >&2
    fail "pages under docs/ that the nav in mkdocs.yml does not list (above): add them to the nav"
  fi
fi

# 3. The generated reference
mkdir -p "$tmp/ref"
python3 tools/docs/gen_grpc_reference.py --out "$tmp/ref/grpc-api.md" 2>/dev/null
regen="run: bash tools/docs/gen_reference.sh (docs/reference/index.md), and commit the pages"
if ! diff -u docs/reference/grpc-api.md "$tmp/ref/grpc-api.md" >"$tmp/grpc.diff"; then
  head -40 "$tmp/grpc.diff" >&2
  fail "docs/reference/grpc-api.md is not what proto/impostor/v1/*.proto say; $regen"
else
  echo "docs_site: docs/reference/grpc-api.md matches the protos"
fi
if [ -x "$bin_dir/impostor" ] && [ -x "$bin_dir/impostor-server" ] && [ -x "$bin_dir/impostor-worker" ]; then
  if python3 tools/docs/gen_cli_reference.py --bin-dir "$bin_dir" --out-dir "$tmp/ref" 2>"$tmp/gen.log"; then
    for page in cli.md server-flags.md worker-flags.md; do
      if ! diff -u "docs/reference/$page" "$tmp/ref/$page" >"$tmp/$page.diff"; then
        head -40 "$tmp/$page.diff" >&2
        fail "docs/reference/$page is not what the binaries in $bin_dir print; $regen"
      else
        echo "docs_site: docs/reference/$page matches $bin_dir"
      fi
    done
  else
    cat "$tmp/gen.log" >&2
    fail "could not run the binaries in $bin_dir for their --help"
  fi
else
  echo "docs_site: SKIPPED the CLI reference check: impostor, impostor-server and impostor-worker are not all built in $bin_dir"
fi

# 4. The tutorials' markers (running them is CTest docs_tutorials)
if python3 tools/docs/run_tutorials.py --list >"$tmp/tutorials.log" 2>&1; then
  echo "docs_site: tutorial markers: ok ($(grep -c ' runs\| instead:' "$tmp/tutorials.log") blocks run, $(grep -c SKIPPED "$tmp/tutorials.log") skipped)"
else
  cat "$tmp/tutorials.log" >&2
  fail "a <!-- tutorial: ... --> marker in docs/tutorials/ is wrong (above)"
fi

exit "$failed"
