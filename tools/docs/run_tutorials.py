#!/usr/bin/env python3
"""Runs the tutorials' command blocks against a real farm (CTest `docs_tutorials`).

Each page under docs/tutorials/ is read top to bottom and its shell blocks
are run in order, in one bash (so a variable set or a server started in one
block is there in the next), as a reader who pastes them into one terminal
would. What runs and what does not is written in the page itself:

* A fenced block whose info string is `sh`, `bash` or `shell` runs; any other
  (`text`, `console`, `cmake`, ...) is shown, never run.
* HTML comments on the lines right before a block (invisible on the site)
  steer the runner; each says why in its own words:

      <!-- tutorial: skip REASON -->       the block is not run; the runner
                                            prints REASON (e.g. apt-get,
                                            systemctl, another machine)
      <!-- tutorial: instead SHELL -->     SHELL runs in its place (e.g. the
                                            head node's name is localhost here)
      <!-- tutorial: expect REGEX -->      the block's output (stdout and
                                            stderr) must match REGEX (Python
                                            re, MULTILINE); may repeat
      <!-- tutorial: timeout SECONDS -->   the block's time limit (default 180)

  An unknown or misplaced marker is an error, so a typo cannot skip a block.
* Blocks run under `set -euo pipefail`: every command of a block must exit 0
  (a command meant to fail says so, e.g. `|| echo "refused: exit $?"`), and
  an unset variable is an error. A block that starts a server ends the
  command with `&` and waits for it by polling (e.g. for its --port-file);
  what a page leaves running is stopped when the page ends (SIGTERM to its
  process group, SIGKILL after 20 s).

Each page starts in a fresh HOME of its own, which holds `impostor/`, a view of
the checkout (its files, linked, and `build/` linked to the build that --bin-dir
is in) and `shared/assets/` beside it (linked to --assets), as the tutorials
expect a clone to be laid out; PATH, TMPDIR and XDG_CACHE_HOME point inside
that HOME too, and IMPOSTOR_SERVER / IMPOSTOR_TOKEN are unset. Everything
lives under one temporary root, removed when every page passed; on a failure
it is kept, its path printed, with the failed block, its output and the last
lines of what the page's background processes printed.

  python3 tools/docs/run_tutorials.py [--bin-dir build/bin] [--assets ../shared/assets]
                                      [--list] [--keep] [PAGE.md ...]

Exit status: 0 all pages passed, 1 a block failed (or a marker is wrong),
77 skipped (binaries or assets missing; CTest SKIP_RETURN_CODE).
Python 3 standard library only.
"""
import argparse
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
RUN_LANGS = {"sh", "bash", "shell"}
FENCE = re.compile(r"^(\s*)(```+|~~~+)\s*([^\s`]*)")
MARKER = re.compile(r"^\s*<!--\s*tutorial:\s*(\w+)\s*(.*?)\s*-->\s*$")
MARKER_START = re.compile(r"^\s*<!--\s*tutorial\b")
DEFAULT_TIMEOUT = 180
BINARIES = ("impostor", "impostor-server", "impostor-worker")
ENV_TAG = "IMPOSTOR_TUTORIAL_ROOT"


class Block:
    def __init__(self, page, index, line, lang, text):
        self.page, self.index, self.line, self.lang, self.text = page, index, line, lang, text
        self.skip = None       # reason
        self.instead = None    # shell run in its place
        self.expect = []
        self.timeout = DEFAULT_TIMEOUT

    @property
    def runs(self):
        return self.lang in RUN_LANGS

    def where(self):
        return f"{self.page}:{self.line} (block {self.index})"


class PageError(Exception):
    pass


def parse(path, shown):
    """Returns the page's code blocks with their markers; raises PageError on a bad marker."""
    lines = open(path, encoding="utf-8").read().split("\n")
    blocks, pending, i, n = [], [], 0, 0
    while i < len(lines):
        line = lines[i]
        m = FENCE.match(line)
        if m:
            indent, fence, lang = m.group(1), m.group(2), m.group(3).lower()
            start, body = i + 1, []
            i += 1
            while i < len(lines) and not (lines[i].strip().startswith(fence) and lines[i].strip().strip(fence[0]) == ""):
                body.append(lines[i][len(indent):] if lines[i].startswith(indent) else lines[i].lstrip())
                i += 1
            if i == len(lines):
                raise PageError(f"{shown}:{start}: code block never closed")
            n += 1
            block = Block(shown, n, start, lang, "\n".join(body) + "\n")
            for lineno, kind, arg in pending:
                if not block.runs:
                    raise PageError(f"{shown}:{lineno}: 'tutorial: {kind}' stands before a ```{lang or '(no language)'} "
                                    f"block, which is never run; markers go before ```sh blocks")
                if kind == "skip":
                    block.skip = arg
                elif kind == "instead":
                    block.instead = arg
                elif kind == "expect":
                    block.expect.append(arg)
                elif kind == "timeout":
                    block.timeout = int(arg)
            if block.skip is not None and block.instead is not None:
                raise PageError(f"{block.where()}: both 'skip' and 'instead'; one says what happens")
            pending = []
            blocks.append(block)
            i += 1
            continue
        mm = MARKER.match(line)
        if mm:
            kind, arg = mm.group(1), mm.group(2)
            if kind not in ("skip", "instead", "expect", "timeout"):
                raise PageError(f"{shown}:{i + 1}: unknown marker 'tutorial: {kind}' (skip, instead, expect, timeout)")
            if kind in ("skip", "instead", "expect") and not arg:
                raise PageError(f"{shown}:{i + 1}: 'tutorial: {kind}' needs its {'reason' if kind == 'skip' else 'text'}")
            if kind == "expect":
                try:
                    re.compile(arg)
                except re.error as e:
                    raise PageError(f"{shown}:{i + 1}: 'tutorial: expect {arg}' is not a regular expression: {e}")
            if kind == "timeout" and not arg.isdigit():
                raise PageError(f"{shown}:{i + 1}: 'tutorial: timeout {arg}': seconds, a whole number")
            pending.append((i + 1, kind, arg))
        elif MARKER_START.match(line):
            raise PageError(f"{shown}:{i + 1}: malformed marker (write <!-- tutorial: KIND ARGS --> on one line)")
        elif pending and line.strip():
            raise PageError(f"{shown}:{pending[0][0]}: 'tutorial: {pending[0][1]}' is not right before a code block")
        i += 1
    if pending:
        raise PageError(f"{shown}:{pending[0][0]}: 'tutorial: {pending[0][1]}' is not followed by a code block")
    if not any(b.runs and b.skip is None for b in blocks):
        raise PageError(f"{shown}: no ```sh block runs; a tutorial that cannot run anything is not tested")
    return blocks


def clone_view(home, build_dir, assets):
    """HOME/impostor: the checkout's entries linked, build/ the build; HOME/shared/assets."""
    view = os.path.join(home, "impostor")
    os.makedirs(view)
    for name in os.listdir(REPO):
        if name in (".git", "build"):
            continue
        os.symlink(os.path.join(REPO, name), os.path.join(view, name))
    os.symlink(build_dir, os.path.join(view, "build"))
    os.makedirs(os.path.join(home, "shared"))
    os.symlink(assets, os.path.join(home, "shared", "assets"))


def driver(blocks, state):
    """The page as one bash script, and which page line each of its lines is (for error messages)."""
    out = ["set -euo pipefail",
           f"trap 'echo $? > \"{state}/exit\"' EXIT"]
    lines = {}
    for b in blocks:
        if not b.runs:
            continue
        log = f"{state}/block-{b.index:02d}.log"
        out.append(f"# {b.where()}")
        if b.skip is not None:
            continue
        out.append(f"exec >\"{log}\" 2>&1 </dev/null")
        out.append(f"echo \"{b.index} $EPOCHREALTIME\" >> \"{state}/started\"")
        if b.instead is not None:
            out.append(b.instead)
            lines[len(out)] = f"{b.page}:{b.line - 1} (tutorial: instead)"
        else:
            for k, text in enumerate(b.text.rstrip("\n").split("\n")):
                out.append(text)
                lines[len(out)] = f"{b.page}:{b.line + 1 + k}"
        out.append(f"echo \"{b.index} $EPOCHREALTIME\" >> \"{state}/done\"")
    out.append("exec >/dev/null 2>&1")
    return "\n".join(out) + "\n", lines


def page_lines(text, script, lines):
    """bash's 'driver.sh: line N:' as the page's 'PAGE:LINE:'."""
    return re.sub(re.escape(script) + r": line (\d+):",
                  lambda m: lines.get(int(m.group(1)), m.group(0)) + ":", text)


def read_marks(path):
    marks = {}
    if os.path.exists(path):
        for line in open(path):
            parts = line.split()
            if len(parts) == 2:
                marks[int(parts[0])] = float(parts[1])
    return marks


def group_alive(pgid):
    try:
        os.killpg(pgid, 0)
        return True
    except ProcessLookupError:
        return False
    except PermissionError:
        return True


def tagged_processes(tag_value):
    """Processes still carrying this run's environment tag (escaped their process group)."""
    found = []
    needle = f"{ENV_TAG}={tag_value}".encode()
    for pid in os.listdir("/proc"):
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            with open(f"/proc/{pid}/environ", "rb") as f:
                if needle in f.read().split(b"\0"):
                    found.append(int(pid))
        except OSError:
            pass
    return found


def stop_page(proc, tag_value):
    """Stops what the page left running: its process group, then anything else it started."""
    pgid = proc.pid
    if proc.poll() is None:
        pass  # timed out: the shell itself is stopped with its group
    for sig, grace in ((signal.SIGTERM, 20.0), (signal.SIGKILL, 5.0)):
        try:
            os.killpg(pgid, sig)
        except ProcessLookupError:
            pass
        deadline = time.monotonic() + grace
        while time.monotonic() < deadline:
            proc.poll()
            if not group_alive(pgid):
                break
            time.sleep(0.05)
        if not group_alive(pgid):
            break
    proc.wait()
    escaped = tagged_processes(tag_value)
    for pid in escaped:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    return escaped


def tail(path, lines):
    try:
        text = open(path, errors="replace").read()
    except OSError:
        return ""
    return "\n".join(text.rstrip("\n").split("\n")[-lines:])


LISTEN = re.compile(r"--listen[= ]+\S*?:(\d+)\b")


def busy_ports(blocks):
    """The fixed ports the page's servers listen on that something else already holds."""
    busy = []
    for b in blocks:
        if not b.runs or b.skip is not None:
            continue
        for port in sorted({int(p) for p in LISTEN.findall(b.instead or b.text)} - {0}):
            with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
                # as the server binds: a port whose last connections are in TIME_WAIT is free
                s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                try:
                    s.bind(("127.0.0.1", port))
                except OSError:
                    busy.append((b, port))
    return busy


def work_logs(home):
    """The *.log files the page wrote in its HOME (servers' and workers' logs)."""
    found = []
    for dirpath, dirnames, filenames in os.walk(home):
        dirnames[:] = [d for d in dirnames if d not in ("impostor", "shared", "tmp", ".cache")
                       and not os.path.islink(os.path.join(dirpath, d))]
        found += [os.path.join(dirpath, f) for f in filenames if f.endswith(".log")]
    return sorted(found)


def run_page(path, shown, blocks, root, args, env_base):
    name = os.path.splitext(os.path.basename(path))[0]
    page_root = os.path.join(root, name)
    home, state = os.path.join(page_root, "home"), os.path.join(page_root, "state")
    os.makedirs(state)
    os.makedirs(os.path.join(home, "tmp"))
    clone_view(home, args.build_dir, args.assets)
    script = os.path.join(state, "driver.sh")
    text, lines = driver(blocks, state)
    with open(script, "w") as f:
        f.write(text)
    env = dict(env_base)
    env.update(HOME=home, TMPDIR=os.path.join(home, "tmp"), TMP=os.path.join(home, "tmp"),
               TEMP=os.path.join(home, "tmp"), XDG_CACHE_HOME=os.path.join(home, ".cache"),
               PATH=args.bin_dir + os.pathsep + env_base.get("PATH", "/usr/bin:/bin"))
    env[ENV_TAG] = page_root

    print(f"== {shown}", flush=True)
    busy = busy_ports(blocks)
    if busy:
        for b, port in busy:
            print(f"FAIL: {shown}: block {b.index} at line {b.line} listens on port {port}, which another process "
                  f"holds (a farm of your own? stop it and run again)")
        return False, 0.0
    t0 = time.monotonic()
    proc = subprocess.Popen(["bash", "--noprofile", "--norc", script], cwd=home, env=env,
                            stdin=subprocess.DEVNULL, stdout=open(os.path.join(state, "shell.log"), "w"),
                            stderr=subprocess.STDOUT, start_new_session=True)
    by_index = {b.index: b for b in blocks}
    timed_out = None
    current, current_since = None, None
    while proc.poll() is None:
        started = read_marks(os.path.join(state, "started"))
        done = read_marks(os.path.join(state, "done"))
        running = [i for i in started if i not in done]
        if running:
            if running[-1] != current:
                current, current_since = running[-1], time.monotonic()
            if time.monotonic() - current_since > by_index[current].timeout:
                timed_out = current
                break
        time.sleep(0.05)
    escaped = stop_page(proc, page_root)
    elapsed = time.monotonic() - t0

    started = read_marks(os.path.join(state, "started"))
    done = read_marks(os.path.join(state, "done"))
    exit_file = os.path.join(state, "exit")
    rc = int(open(exit_file).read().strip() or 1) if os.path.exists(exit_file) else None
    failure = None
    for b in blocks:
        if b.runs and b.skip is not None:
            print(f"   block {b.index} (line {b.line}) SKIPPED: {b.skip}")
        if b.index not in started:
            continue
        log = os.path.join(state, f"block-{b.index:02d}.log")
        if b.index not in done:
            why = (f"ran past its {b.timeout} s limit (tutorial: timeout N)" if timed_out == b.index
                   else f"exited {rc}")
            failure = (b, why)
            break
        output = open(log, errors="replace").read() if os.path.exists(log) else ""
        missing = [e for e in b.expect if not re.search(e, output, re.M)]
        if missing:
            failure = (b, "printed nothing matching " + ", ".join(repr(e) for e in missing))
            break
        print(f"   block {b.index} (line {b.line}) ok, {done[b.index] - started[b.index]:.1f} s"
              + (" (instead: " + b.instead + ")" if b.instead is not None else ""))
    if failure is None and rc not in (0, None):
        failure = (None, f"the page's shell exited {rc} after its last block")
    if failure is None and escaped:
        failure = (None, f"processes {escaped} left their process group and were still running when the page ended")
    if failure is None:
        print(f"   passed in {elapsed:.1f} s")
        return True, elapsed

    b, why = failure
    print(f"FAIL: {shown}: " + (f"block {b.index} at line {b.line} {why}" if b else why))
    if b is not None:
        shown_text = b.instead if b.instead is not None else b.text
        print("---- the block:\n" + shown_text.rstrip("\n"))
        print("---- its output (last 80 lines):\n"
              + page_lines(tail(os.path.join(state, f"block-{b.index:02d}.log"), 80), script, lines))
    for other in blocks:
        if b is not None and other.index >= b.index:
            break
        log = os.path.join(state, f"block-{other.index:02d}.log")
        if other.index in done and os.path.exists(log) and os.path.getmtime(log) > done[other.index] + 0.5:
            # written to after its block ended: a background process it started
            print(f"---- background output of block {other.index} (line {other.line}), last 30 lines:\n"
                  + tail(log, 30))
    for log in work_logs(home):
        print(f"---- {os.path.relpath(log, home)}, last 20 lines:\n" + tail(log, 20))
    shell = tail(os.path.join(state, "shell.log"), 20)
    if shell:
        print("---- the shell's own output:\n" + shell)
    print(f"---- the page's files are in {page_root}")
    return False, elapsed


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin-dir", default=os.path.join(REPO, "build", "bin"))
    ap.add_argument("--assets", default=os.path.join(os.path.dirname(REPO), "shared", "assets"))
    ap.add_argument("--list", action="store_true", help="check the markers and list what would run; run nothing")
    ap.add_argument("--keep", action="store_true", help="keep the temporary root even when every page passed")
    ap.add_argument("pages", nargs="*")
    args = ap.parse_args()
    args.bin_dir = os.path.realpath(args.bin_dir)
    args.build_dir = os.path.dirname(args.bin_dir)
    args.assets = os.path.abspath(args.assets)

    pages = args.pages or sorted(
        os.path.join(REPO, "docs", "tutorials", f) for f in os.listdir(os.path.join(REPO, "docs", "tutorials"))
        if f.endswith(".md"))
    parsed = []
    for page in pages:
        shown = os.path.relpath(os.path.abspath(page), REPO)
        try:
            parsed.append((page, shown, parse(page, shown)))
        except (PageError, OSError) as e:
            print(f"run_tutorials: FAIL: {e}")
            return 1
    if args.list:
        for page, shown, blocks in parsed:
            print(f"== {shown}")
            for b in blocks:
                if b.runs:
                    what = ("SKIPPED: " + b.skip if b.skip is not None else
                            "instead: " + b.instead if b.instead is not None else "runs")
                    print(f"   block {b.index} (line {b.line}) {what}"
                          + "".join(f"; expect {e!r}" for e in b.expect))
        return 0

    missing = [b for b in BINARIES if not os.access(os.path.join(args.bin_dir, b), os.X_OK)]
    if missing:
        print(f"run_tutorials: SKIPPED: {', '.join(missing)} not built in {args.bin_dir}")
        return 77
    if not os.path.isdir(args.assets):
        print(f"run_tutorials: SKIPPED: no test assets at {args.assets}")
        return 77

    env = {k: v for k, v in os.environ.items()
           if k not in ("IMPOSTOR_SERVER", "IMPOSTOR_TOKEN", "IMPOSTOR_CACHE_DIR", "CDPATH", "BASH_ENV", "ENV")}
    root = tempfile.mkdtemp(prefix="impostor-tutorials-")
    results = []
    try:
        for page, shown, blocks in parsed:
            results.append((shown,) + run_page(page, shown, blocks, root, args, env))
    except BaseException:
        print(f"run_tutorials: interrupted; files kept in {root}")
        raise
    failed = [r for r in results if not r[1]]
    total = sum(r[2] for r in results)
    if failed:
        print(f"run_tutorials: FAIL: {', '.join(r[0] for r in failed)} ({total:.0f} s); everything kept in {root}")
        return 1
    if args.keep:
        print(f"run_tutorials: {len(results)} tutorials passed in {total:.0f} s; kept {root}")
        return 0
    shutil.rmtree(root)
    print(f"run_tutorials: {len(results)} tutorials passed in {total:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
