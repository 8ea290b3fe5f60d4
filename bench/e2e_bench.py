#!/usr/bin/env python3
"""The work of bench/e2e_bench.sh (issue 45); run that script, not this file.

Everything is timed in one run on this machine:

1. End to end, as a user runs it: impostor-server with one local worker, the
   CLI's `impostor bake MODEL --layout hemi-octahedral --frames 12
   --resolution 2048`: the first (cold) bake right after the server says it
   listens, as deploy/quickstart.sh does, then N warm bakes on the same farm.
2. The same request in process (build/bin/bake_stages), N times, each run
   interleaved with a warm farm bake (the order alternates), so load from
   other processes on a shared machine hits both sides alike.
3. build/bin/isolated_load_bench on MODEL: isolated against in-process load.
4. `impostor fetch KEY --out DIR` of the result just baked against nginx +
   curl serving exactly the same files, alternating rounds with Cache::Get
   and curl against the farm's own HTTP front end.
5. The farm's /metrics stage sums over the warm bakes beside bake_stages'
   stages, so the difference between the two is attributed.
6. With --blender (bench/compare_blender.sh): Blender 3.4 Cycles rendering
   the last warm bake's own views (e2e_blender.py, bench/blender_views.py), timed from
   process start to exit, against the warm end-to-end median.

Nothing is asserted; any step that fails stops the bench with
"e2e_bench: FAILED (step): reason" and exit status 1. Every file goes under
--work, which the calling script removes (and the processes this starts are
listed in WORK/pids/ for its trap).
"""
import argparse
import json
import os
import re
import resource
import signal
import socket
import statistics
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from pathlib import Path

import e2e_blender
from e2e_errors import BenchError

LAYOUT, FRAMES, RESOLUTION = "hemi-octahedral", 12, 2048
# Stages the worker reports in BakeTimings and /metrics exports as
# impostor_bake_stage_seconds{stage=...} (server/metrics/farm_metrics.cc).
STAGES = ["download", "load", "render", "readback", "encode", "store"]
# Worker token name of --local-workers on a server with its own SQLite store
# (LocalWorkerTokenName in server/commands/token_command.cc).
LOCAL_WORKER_TOKEN = "local-workers"


LOADS = []


def log(msg):
    # Each line says how busy the machine was: on a shared machine a slow
    # step is often someone else's compile.
    LOADS.append(os.getloadavg()[0])
    print(f"{msg}  [load average {LOADS[-1]:.2f}]", flush=True)


def median(xs):
    return statistics.median(xs)


def span(xs, digits=2):
    return f"{min(xs):.{digits}f}–{max(xs):.{digits}f}"


def tail(path, n=15):
    try:
        lines = Path(path).read_text(errors="replace").splitlines()
    except OSError:
        return ""
    return "\n".join("    " + line for line in lines[-n:])


def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def proc_cpu(pid, with_children):
    """CPU seconds of a live process from /proc (children: those it reaped)."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2:].split()
    # After "pid (comm) ": state is fields[0]; utime..cstime are 11..14.
    ticks = int(fields[11]) + int(fields[12])
    if with_children:
        ticks += int(fields[13]) + int(fields[14])
    return ticks / os.sysconf("SC_CLK_TCK")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Bench:
    def __init__(self, a):
        self.a = a
        self.build = Path(a.build).resolve()
        self.bin = self.build / "bin"
        self.work = Path(a.work)
        self.model = Path(a.model).resolve()
        self.pids = self.work / "pids"
        self.pids.mkdir(exist_ok=True)
        self.logs = self.work / "logs"
        self.logs.mkdir(exist_ok=True)
        self.tmp = self.work / "tmp"
        self.tmp.mkdir(exist_ok=True)
        self.env = dict(os.environ, TMPDIR=str(self.tmp), IMPOSTOR_CACHE_DIR=str(self.work / "cli-cache"),
                        XDG_CACHE_HOME=str(self.work / "xdg-cache"))
        self.env.pop("IMPOSTOR_SERVER", None)
        self.env.pop("IMPOSTOR_TOKEN", None)
        self.server = None
        self.counter = 0

    def fresh(self, name):
        """A new path under WORK that does not exist yet."""
        self.counter += 1
        return self.work / f"{name}-{self.counter}"

    def note_pid(self, name, pid):
        (self.pids / name).write_text(f"{pid}\n")

    def drop_pid(self, name):
        (self.pids / name).unlink(missing_ok=True)

    def run(self, step, cmd, timeout=900, env=None, stdout=subprocess.PIPE, stderr=None, check=True):
        """Runs cmd; returns (seconds, CompletedProcess, client CPU seconds)."""
        cpu0 = children_cpu()
        t0 = time.perf_counter()
        try:
            r = subprocess.run([str(c) for c in cmd], stdout=stdout, stderr=stderr, timeout=timeout,
                               env=env or self.env, text=True)
        except subprocess.TimeoutExpired:
            raise BenchError(step, f"{Path(str(cmd[0])).name} ran past {timeout} s")
        wall = time.perf_counter() - t0
        cpu = children_cpu() - cpu0
        if check and r.returncode != 0:
            detail = (r.stdout or "")[-2000:] if isinstance(r.stdout, str) else ""
            raise BenchError(step, f"`{' '.join(str(c) for c in cmd)}` exited {r.returncode}\n{detail}")
        return wall, r, cpu

    # ---- the farm -------------------------------------------------------

    def start_farm(self):
        data = self.work / "farm"
        data.mkdir()
        # Purging results between warm bakes needs an admin token, so the farm
        # runs with --auth token (the quickstart's loopback farm has none).
        # Tokens are checked against an in-memory cache (--token-cache-ttl-ms,
        # 2 s), so this adds microseconds per call, not a database read.
        _, r, _ = self.run("token", [self.bin / "impostor-server", "token", "create", "--data", data, "--role",
                                     "admin", "--name", "e2e-bench"], stderr=subprocess.PIPE)
        secret = r.stdout.strip().splitlines()[0].strip() if r.stdout.strip() else ""
        if not secret.startswith("imp_"):
            raise BenchError("token", f"`impostor-server token create` printed no secret: {r.stdout!r}")
        self.token = self.work / "admin.token"
        fd = os.open(self.token, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        os.write(fd, (secret + "\n").encode())
        os.close(fd)
        self.token_secret = secret
        self.server_out = self.logs / "server.out"
        self.server_err = self.logs / "server.err"
        cmd = [self.bin / "impostor-server", "--listen=127.0.0.1:0", "--http-listen=127.0.0.1:0", f"--data={data}",
               "--local-workers=1", "--auth=token",
               # Purged results' blobs are deleted at once, so a warm bake
               # uploads its maps again as a new result does (with the
               # default 600 s grace they would stay and `store` would only
               # find them present).
               "--store-eviction-grace-seconds=0", "--shutdown-grace-seconds=5"]
        with open(self.server_out, "w") as out, open(self.server_err, "w") as err:
            self.server = subprocess.Popen([str(c) for c in cmd], stdout=out, stderr=err, env=self.env)
        self.note_pid("server", self.server.pid)
        deadline = time.monotonic() + 60
        grpc = http = None
        while time.monotonic() < deadline and (grpc is None or http is None):
            if self.server.poll() is not None:
                raise BenchError("farm", f"impostor-server exited {self.server.returncode}:\n{tail(self.server_err)}")
            text = self.server_out.read_text()
            m = re.search(r"impostor-server listening on (\S+)", text)
            grpc = m.group(1) if m else None
            m = re.search(r"impostor-server http listening on (\S+)", text)
            http = m.group(1) if m else None
            time.sleep(0.02)
        if grpc is None or http is None:
            raise BenchError("farm", "impostor-server did not say where it listens within 60 s:\n"
                             + tail(self.server_err))
        self.grpc, self.http = grpc, http
        log(f"farm: impostor-server pid {self.server.pid}, gRPC {grpc}, HTTP {http}, one local worker, data {data}")

    def worker_pid(self):
        pids = re.findall(r"event=worker_started index=0 pid=(\d+)", self.server_err.read_text())
        if not pids:
            return None
        pid = int(pids[-1])
        self.note_pid("worker", pid)
        return pid

    def stop_farm(self):
        if self.server is None:
            return
        worker = self.worker_pid()
        self.server.send_signal(signal.SIGTERM)
        try:
            self.server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.server.kill()
            self.server.wait()
        self.drop_pid("server")
        if worker is not None:
            for _ in range(100):
                if proc_cpu(worker, False) is None:
                    break
                time.sleep(0.05)
            self.drop_pid("worker")
        self.server = None

    def metrics(self):
        req = urllib.request.Request(f"http://{self.http}/metrics",
                                     headers={"Authorization": f"Bearer {self.token_secret}"})
        try:
            with urllib.request.urlopen(req, timeout=30) as resp:
                text = resp.read().decode()
        except OSError as e:
            raise BenchError("metrics", f"GET http://{self.http}/metrics: {e}")
        values = {}
        for line in text.splitlines():
            m = re.match(r'^([a-zA-Z_:][a-zA-Z0-9_:]*)(\{[^}]*\})?\s+(\S+)$', line)
            if not m:
                continue
            labels = dict(re.findall(r'(\w+)="([^"]*)"', m.group(2) or ""))
            values[(m.group(1), tuple(sorted(labels.items())))] = float(m.group(3))
        return values

    @staticmethod
    def metric(values, name, **labels):
        return values.get((name, tuple(sorted(labels.items()))), 0.0)

    def farm_figures(self, before, after):
        """What the worker reported for the bakes between two scrapes."""
        d = lambda name, **l: self.metric(after, name, **l) - self.metric(before, name, **l)
        f = {s: d("impostor_bake_stage_seconds_sum", product="atlas", stage=s) for s in STAGES}
        f["total"] = d("impostor_bake_seconds_sum", product="atlas")
        f["bakes"] = d("impostor_jobs_completed_total", product="atlas")
        f["lease_latency"] = d("impostor_lease_latency_seconds_sum", product="atlas")
        return f

    def bake(self, step):
        out = self.fresh("bake-out")
        server_cpu0 = proc_cpu(self.server.pid, False)
        worker = self.worker_pid()
        worker_cpu0 = proc_cpu(worker, True) if worker else None
        before = self.metrics()
        errlog = self.logs / f"{step}.stderr"
        with open(errlog, "w") as err:
            wall, r, client_cpu = self.run(
                step, [self.bin / "impostor", "bake", self.model, "--layout", LAYOUT, "--frames", FRAMES,
                       "--resolution", RESOLUTION, "--server", self.grpc, "--token-file", self.token, "--out", out,
                       "--json"], stderr=err, check=False)
        if r.returncode != 0:
            raise BenchError(step, f"`impostor bake` exited {r.returncode}:\n{tail(errlog)}\n{r.stdout[-1000:]}")
        after = self.metrics()
        try:
            report = json.loads(r.stdout)
        except ValueError:
            raise BenchError(step, f"`impostor bake --json` printed no JSON: {r.stdout[-500:]!r}")
        if report.get("cached"):
            raise BenchError(step, "answered from the result cache: the purge before it did not drop the result")
        farm = self.farm_figures(before, after)
        if farm["bakes"] != 1:
            raise BenchError(step, f"the farm delivered {farm['bakes']:.0f} bakes during it, not 1")
        worker_after = self.worker_pid()
        cpu = None
        if worker and worker_after == worker and server_cpu0 is not None and worker_cpu0 is not None:
            s1, w1 = proc_cpu(self.server.pid, False), proc_cpu(worker, True)
            if s1 is not None and w1 is not None:
                cpu = {"client": client_cpu, "server": s1 - server_cpu0, "worker": w1 - worker_cpu0}
        files = report.get("files") or []
        return {"wall": wall, "key": report["cache_key"], "farm": farm, "cpu": cpu, "files": len(files) + 1,
                "out": out}

    def purge(self, key):
        """Drops the result so the next identical request really bakes.

        The warm bakes must redo the work, not hit the result cache. Changing
        the cache key instead does not fit: the key (ComputeCacheKey) takes
        only parameters that change the work (an explicit default such as
        --supersampling 2 gives one more key, not N), the model's file name
        is not in it, and new mesh bytes (padding the GLB's JSON) would add
        an upload the in-process side does not have. Instead the farm keeps
        the very same request and drops its result between bakes with
        `impostor admin purge --worker local-workers`
        (AdminService.PurgeWorkerResults: the result and, with
        --store-eviction-grace-seconds=0, every blob only it used),
        so each warm bake leases, loads, renders, encodes, uploads all maps
        and the CLI downloads them, exactly as the first bake of a key does.
        The purge itself is not timed."""
        _, r, _ = self.run("purge", [self.bin / "impostor", "admin", "purge", "--worker", LOCAL_WORKER_TOKEN,
                                     "--server", self.grpc, "--token-file", self.token, "--json"],
                           stderr=subprocess.STDOUT, check=False)
        try:
            report = json.loads(r.stdout.strip().splitlines()[-1])
        except (ValueError, IndexError):
            report = {}
        if r.returncode != 0 or key not in (report.get("cache_keys") or []):
            raise BenchError("purge", f"`impostor admin purge` did not drop {key}: {r.stdout[-1000:]}")
        if not report.get("blobs_removed"):
            raise BenchError("purge", "no blob removed: the next bake would find its maps in the store")

    # ---- in process -----------------------------------------------------

    def in_process(self, step):
        """bake_stages --repeat 2; the second bake of the process is the
        warm one (the farm's worker has baked before too)."""
        _, r, _ = self.run(step, [self.bin / "bake_stages", "--layout", LAYOUT, "--frames", FRAMES, "--resolution",
                                  RESOLUTION, "--repeat", "2", self.model], stderr=subprocess.STDOUT)
        (self.logs / f"{step}.out").write_text(r.stdout)
        runs = []
        for m in re.finditer(r"run (\d+): wall ([\d.]+) s \(cpu ([\d.]+) s\); recorded: load ([\d.]+) render "
                             r"([\d.]+) readback ([\d.]+) encode ([\d.]+)", r.stdout):
            runs.append({"wall": float(m.group(2)), "cpu": float(m.group(3)), "load": float(m.group(4)),
                         "render": float(m.group(5)), "readback": float(m.group(6)), "encode": float(m.group(7))})
        quality = [float(x) for x in re.findall(r"event=quality_pass .* seconds=([\d.]+)", r.stdout)]
        if len(runs) != 2:
            raise BenchError(step, f"bake_stages printed {len(runs)} runs, not 2:\n{r.stdout[-1500:]}")
        for run, q in zip(runs, quality):
            run["quality"] = q
        m = re.search(r"^bake_stages: .* on (.+)$", r.stdout, re.M)
        self.device = m.group(1) if m else "?"
        return runs

    # ---- fetch against nginx + curl ---------------------------------------

    def farm_http_flag(self, http):
        # With: the large files from the farm's HTTP front end; without:
        # everything over gRPC ("none" also overrides $IMPOSTOR_FARM_HTTP).
        return ["--farm-http", f"http://{self.http}" if http else "none"]

    def fetch_cmd(self, key, out, http=False):
        return [self.bin / "impostor", "fetch", key, "--out", out, "--server", self.grpc, "--token-file", self.token,
                "--quiet", *self.farm_http_flag(http)]

    def cache_get_cmd(self, key, cache_dir, http=False):
        return [self.bin / "impostor", "cache", "get", key, "--cache-dir", cache_dir, "--server", self.grpc,
                "--token-file", self.token, "--quiet", *self.farm_http_flag(http)]

    def start_nginx(self, www, name, probe):
        """nginx serving `www` on a free loopback port, answering `probe`
        (a file under it): (its prefix, base URL, curl's common arguments)."""
        # nginx's workers may run as another user: let them in.
        os.chmod(self.work, 0o711)
        for p in [www, *www.rglob("*")]:
            os.chmod(p, 0o755 if p.is_dir() else 0o644)
        prefix = self.work / name
        prefix.mkdir()
        port = free_port()
        conf = prefix / "nginx.conf"
        t = str(prefix)
        conf.write_text(
            f"daemon on; worker_processes 1; pid {prefix}/nginx.pid;\n"
            f"error_log {prefix}/error.log;\n"
            "events { worker_connections 64; }\n"
            "http { access_log off; sendfile on; tcp_nopush on;\n"
            f"  client_body_temp_path {t}/body; proxy_temp_path {t}/proxy; fastcgi_temp_path {t}/fastcgi;\n"
            f"  uwsgi_temp_path {t}/uwsgi; scgi_temp_path {t}/scgi;\n"
            f"  server {{ listen 127.0.0.1:{port}; root {www}; }} }}\n")
        self.run("nginx", [self.a.nginx, "-c", conf, "-p", prefix], stdout=subprocess.PIPE,
                 stderr=subprocess.STDOUT)
        pidfile = prefix / "nginx.pid"
        for _ in range(100):
            if pidfile.exists() and pidfile.read_text().strip():
                break
            time.sleep(0.05)
        else:
            raise BenchError("nginx", f"no pid file; error log:\n{tail(prefix / 'error.log')}")
        self.note_pid(name, pidfile.read_text().strip())
        base = f"http://127.0.0.1:{port}/"
        curl_base = ["curl", "-sf", "--create-dirs"]
        first = urllib.parse.quote(probe)
        # nginx binds after forking: wait until it answers.
        for _ in range(100):
            ok = subprocess.run(curl_base + ["-o", "/dev/null", base + first], env=self.env).returncode == 0
            if ok:
                break
            time.sleep(0.05)
        else:
            raise BenchError("nginx", f"{base}{probe} never answered; error log:\n{tail(prefix / 'error.log')}")
        return prefix, base, curl_base

    def stop_nginx(self, prefix, name):
        pidfile = prefix / "nginx.pid"
        os.kill(int(pidfile.read_text().strip()), signal.SIGQUIT)
        for _ in range(100):
            if not pidfile.exists():
                break
            time.sleep(0.05)
        self.drop_pid(name)

    def fetch_pairs(self, key):
        www = self.work / "www"
        # The reference copy: exactly the files `impostor fetch` writes.
        self.run("fetch", self.fetch_cmd(key, www), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        files = sorted(p.relative_to(www).as_posix() for p in www.rglob("*") if p.is_file())
        nbytes = sum((www / f).stat().st_size for f in files)
        if not files:
            raise BenchError("fetch", "`impostor fetch` wrote no file")
        prefix, base, curl_base = self.start_nginx(www, "nginx", files[0])
        log(f"fetch: result {key[:12]}…: {len(files)} files, {nbytes / 1e6:.1f} MB; nginx on {base}")

        def curl(dest):
            cmd = list(curl_base)  # one process, one connection for all files
            for f in files:
                cmd += ["-o", str(dest / f), base + urllib.parse.quote(f)]
            return cmd

        # The same curl against the farm's own HTTP front end (what a browser
        # or a game without the SDK pays fetching a result from the farm):
        # the token goes in a header file, not on the command line.
        headers = self.work / "farm-headers.txt"
        fd = os.open(headers, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        os.write(fd, f"Authorization: Bearer {self.token_secret}\n".encode())
        os.close(fd)
        farm_base = f"http://{self.http}/api/v1/results/{key}/files/"

        def farm_curl(dest):
            cmd = list(curl_base) + ["-H", f"@{headers}"]
            for f in files:
                cmd += ["-o", str(dest / f), farm_base + urllib.parse.quote(f)]
            return cmd

        curl_s, fetch_s, curl_cpu, fetch_cpu, server_cpu = [], [], [], [], []
        cache_s, cache_cpu, farm_s = [], [], []
        http_s, http_cpu, http_server_cpu, cache_http_s, cache_http_cpu = [], [], [], [], []
        # Rotated, so that no client always runs first (or right after another).
        clients = ["curl", "fetch", "cache", "farm-http", "fetch-http", "cache-http"]
        orders = [clients[k:] + clients[:k] for k in range(len(clients))]
        for i in range(self.a.fetch_pairs):
            for what in orders[i % len(orders)]:
                dest = self.fresh(f"{what}-out")
                if what == "curl":
                    wall, _, cpu = self.run("curl", curl(dest), stderr=subprocess.PIPE)
                    curl_s.append(wall)
                    curl_cpu.append(cpu)
                elif what == "farm-http":
                    wall, _, _ = self.run("curl from the farm", farm_curl(dest), stderr=subprocess.PIPE)
                    farm_s.append(wall)
                elif what in ("cache", "cache-http"):
                    # Cache::Get into a fresh cache directory (`impostor cache
                    # get`): installed under DEST/entries/KEY.
                    wall, r, cpu = self.run("impostor cache get", self.cache_get_cmd(key, dest, what == "cache-http"),
                                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
                    if "farm_http_fallback" in r.stderr or "blob_source_failed" in r.stderr:
                        raise BenchError(what, f"fell back to gRPC:\n{r.stderr[-1500:]}")
                    (cache_s if what == "cache" else cache_http_s).append(wall)
                    (cache_cpu if what == "cache" else cache_http_cpu).append(cpu)
                    entry = dest / "entries" / key
                    got = sum(1 for p in entry.rglob("*") if p.is_file() and p.name in files)
                    if got != len(files):
                        raise BenchError(what, f"installed {got} of the result's {len(files)} files in {entry}")
                    subprocess.run(["rm", "-rf", str(dest)])
                    continue
                else:
                    # A fresh --out and a fresh cache dir: a real download
                    # every time (fetch from a farm keeps files already in
                    # DIR; the cache dir is for --mirror fetches, set anyway).
                    env = dict(self.env, IMPOSTOR_CACHE_DIR=str(self.fresh("fetch-cache")))
                    http = what == "fetch-http"
                    server0 = proc_cpu(self.server.pid, False)
                    wall, r, cpu = self.run("impostor fetch", self.fetch_cmd(key, dest, http), env=env,
                                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
                    server1 = proc_cpu(self.server.pid, False)
                    if "farm_http_fallback" in r.stderr:
                        raise BenchError(what, f"fell back to gRPC:\n{r.stderr[-1500:]}")
                    (http_s if http else fetch_s).append(wall)
                    (http_cpu if http else fetch_cpu).append(cpu)
                    if server0 is not None and server1 is not None:
                        (http_server_cpu if http else server_cpu).append(server1 - server0)
                got = sum(1 for p in dest.rglob("*") if p.is_file())
                if got != len(files):
                    raise BenchError(what, f"wrote {got} files, not {len(files)}")
                subprocess.run(["rm", "-rf", str(dest)])
        self.stop_nginx(prefix, "nginx")
        return {"files": len(files), "mb": nbytes / 1e6, "curl": curl_s, "fetch": fetch_s, "curl_cpu": curl_cpu,
                "fetch_cpu": fetch_cpu, "server_cpu": server_cpu, "cache": cache_s, "cache_cpu": cache_cpu,
                "farm_http": farm_s, "fetch_http": http_s, "fetch_http_cpu": http_cpu,
                "http_server_cpu": http_server_cpu, "cache_http": cache_http_s, "cache_http_cpu": cache_http_cpu}

    # ---- a batch of results: bake-batch of cached assets against curl ---------

    def batch_fetch(self):
        """`impostor bake-batch` of BATCH_ASSETS requests already baked (every
        one a cache hit: FindMissingBlobs, SubmitBake, then each result's
        download), against curl fetching the same files from nginx in one
        process: what a CI job re-running a batch pays over a plain download."""
        assets = [{"path": str(self.model), "name": f"frames{f}", "frames": f}
                  for f in range(4, 4 + self.a.batch_assets)]
        spec = self.work / "batch.json"
        spec.write_text(json.dumps({"defaults": {"layout": LAYOUT, "resolution": 256}, "assets": assets}))

        def batch_cmd(out, http=False):
            return [self.bin / "impostor", "bake-batch", spec, "--out", out, "--server", self.grpc, "--token-file",
                    self.token, "--quiet", "--json", *self.farm_http_flag(http)]

        www = self.work / "batch-www"
        wall, r, _ = self.run("bake-batch", batch_cmd(www), stderr=subprocess.PIPE, timeout=1800)
        summary = json.loads(r.stdout.strip().splitlines()[-1])
        if summary.get("succeeded") != len(assets):
            raise BenchError("bake-batch", f"summary: {summary}")
        files = sorted(p.relative_to(www).as_posix() for p in www.rglob("*") if p.is_file())
        nbytes = sum((www / f).stat().st_size for f in files)
        log(f"batch: {len(assets)} results baked in {wall:.1f} s: {len(files)} files, {nbytes / 1e6:.1f} MB")
        prefix, base, curl_base = self.start_nginx(www, "nginx-batch", files[0])
        batch_s, batch_cpu, curl_s, curl_cpu, http_s, http_cpu = [], [], [], [], [], []
        clients = ["curl", "batch", "batch-http"]
        for i in range(self.a.fetch_pairs):
            for what in clients[i % 3:] + clients[:i % 3]:
                dest = self.fresh(f"batch-{what}")
                if what == "curl":
                    cmd = list(curl_base)
                    for f in files:
                        cmd += ["-o", str(dest / f), base + urllib.parse.quote(f)]
                    wall, _, cpu = self.run("curl", cmd, stderr=subprocess.PIPE)
                    curl_s.append(wall)
                    curl_cpu.append(cpu)
                else:
                    http = what == "batch-http"
                    wall, r, cpu = self.run("bake-batch", batch_cmd(dest, http), stderr=subprocess.PIPE)
                    summary = json.loads(r.stdout.strip().splitlines()[-1])
                    if summary.get("cached") != len(assets):
                        raise BenchError("bake-batch", f"not every asset was a cache hit: {summary}")
                    if "farm_http_fallback" in r.stderr:
                        raise BenchError(what, f"fell back to gRPC:\n{r.stderr[-1500:]}")
                    (http_s if http else batch_s).append(wall)
                    (http_cpu if http else batch_cpu).append(cpu)
                got = sum(1 for p in dest.rglob("*") if p.is_file())
                if got != len(files):
                    raise BenchError(what, f"wrote {got} files, not {len(files)}")
                subprocess.run(["rm", "-rf", str(dest)])
        self.stop_nginx(prefix, "nginx-batch")
        return {"results": len(assets), "files": len(files), "mb": nbytes / 1e6, "batch": batch_s,
                "batch_cpu": batch_cpu, "curl": curl_s, "curl_cpu": curl_cpu, "batch_http": http_s,
                "batch_http_cpu": http_cpu}

    def batch_rows(self, b):
        bm, cm = median(b["batch"]), median(b["curl"])
        return [
            f"| `impostor bake-batch` of {b['results']} cached requests (median of {len(b['batch'])}) | {bm:.3f} s "
            f"({span(b['batch'], 3)}) | {b['files']} files, {b['mb']:.1f} MB (DamagedHelmet at {b['results']} frame "
            f"counts, 256 px); every request a cache hit, each result downloaded; CPU s: CLI "
            f"{median(b['batch_cpu']):.3f} |",
            f"| nginx + curl, same files, one process (median of {len(b['curl'])}) | {cm:.3f} s "
            f"({span(b['curl'], 3)}) | alternating; CPU s: curl {median(b['curl_cpu']):.3f} |",
            f"| **batch / nginx + curl** | **{bm / cm:.2f}×** | target ≤ 1.25 |",
            f"| `impostor bake-batch --farm-http` (median of {len(b['batch_http'])}) | "
            f"{median(b['batch_http']):.3f} s ({span(b['batch_http'], 3)}) | large files from the farm's HTTP "
            f"front end; CPU s: CLI {median(b['batch_http_cpu']):.3f} |",
            f"| **batch --farm-http / nginx + curl** | **{median(b['batch_http']) / cm:.2f}×** | target ≤ 1.25 |",
        ]

    # ---- isolated load ----------------------------------------------------

    def isolated_load(self):
        _, r, _ = self.run("isolated_load_bench", [self.bin / "isolated_load_bench", self.model],
                           stderr=subprocess.STDOUT)
        lines = r.stdout.splitlines()
        header = next((l for l in lines if l.startswith("| asset")), None)
        row = next((l for l in lines if l.startswith(f"| {self.model.name} ")), None)
        if header is None or row is None:
            raise BenchError("isolated_load_bench", f"no row for {self.model.name}:\n{r.stdout[-1500:]}")
        cells = [c.strip() for c in row.split("|")[1:-1]]
        names = [c.strip() for c in header.split("|")[1:-1]]
        # The bench's columns change as the loader does: take the in-process
        # load and every "... / in-process" ratio by name; the last one is the
        # path the worker takes today.
        try:
            fig = dict(zip(names, cells))
            in_process = float(next(v for k, v in fig.items() if k.startswith("in-process load")))
            ratios = [(k[: -len(" / in-process")], float(v.split()[0])) for k, v in fig.items()
                      if k.endswith("/ in-process")]
        except (StopIteration, ValueError):
            ratios = []
        if not ratios:
            raise BenchError("isolated_load_bench", f"cannot read its table:\n{header}\n{row}")
        return {"in_process": in_process, "ratios": ratios, "header": header, "row": row}

    # ---- the run ------------------------------------------------------------

    def main(self):
        n = self.a.warm
        load0 = os.getloadavg()
        # A copy of the bench bundled with its binaries (tools/gpu_check)
        # says which commit they were built from: the folder it runs from is
        # not that checkout.
        rev = os.environ.get("E2E_BENCH_COMMIT") or subprocess.run(
            ["git", "-C", str(Path(__file__).resolve().parent.parent), "rev-parse", "--short", "HEAD"],
            capture_output=True, text=True).stdout.strip() or "?"
        dirty = [] if os.environ.get("E2E_BENCH_COMMIT") else subprocess.run(
            ["git", "-C", str(Path(__file__).resolve().parent.parent), "status", "--porcelain",
             "--untracked-files=no", "--", "server", "worker", "client", "common", "proto"],
            capture_output=True, text=True).stdout.split("\n")
        dirty = [l for l in dirty if l.strip()]
        if dirty:
            rev += f" + {len(dirty)} uncommitted source files the binaries may hold"
        version = subprocess.run([str(self.bin / "impostor-server"), "--version"], capture_output=True,
                                 text=True).stdout.strip()
        log(f"e2e_bench: {self.model.name}, {LAYOUT} {FRAMES}x{FRAMES} frames, {RESOLUTION} px; {n} warm bakes, "
            f"{self.a.fetch_pairs} fetch pairs; {os.cpu_count()} CPUs, load average {load0[0]:.2f}; "
            f"{version}, commit {rev}")
        self.start_farm()

        cold = self.bake("cold bake")
        log(f"cold bake: {cold['wall']:.2f} s end to end (worker's bake {cold['farm']['total']:.2f} s, "
            f"submit to lease {cold['farm']['lease_latency']:.2f} s), key {cold['key'][:12]}…")
        key = cold["key"]

        warm, inproc = [], []
        for i in range(0 if self.a.fetch_only else n):
            order = ["farm", "inproc"] if i % 2 == 0 else ["inproc", "farm"]
            for what in order:
                if what == "farm":
                    self.purge(key)
                    b = self.bake(f"warm bake {i + 1}")
                    if b["key"] != key:
                        raise BenchError("warm bake", f"cache key {b['key']} differs from the cold bake's {key}")
                    warm.append(b)
                    log(f"warm bake {i + 1}/{n}: {b['wall']:.2f} s end to end (worker's bake "
                        f"{b['farm']['total']:.2f} s)")
                else:
                    runs = self.in_process(f"in process {i + 1}")
                    inproc.append(runs)
                    log(f"in process {i + 1}/{n}: {runs[1]['wall']:.2f} s (first bake of the process "
                        f"{runs[0]['wall']:.2f} s), cpu {runs[1]['cpu']:.2f} s")

        blender = None
        if self.a.blender and warm:
            blender = e2e_blender.render_views(self, warm[-1]["out"])
            log(f"blender: {blender['views']} views at {blender['pixels']} px in {blender['seconds']:.2f} s "
                f"({blender['how']}): {blender['seconds'] / median([b['wall'] for b in warm]):.1f}x the warm "
                f"end-to-end median")
        fetch = None
        if self.a.fetch_pairs > 0:
            fetch = self.fetch_pairs(key)
            log(f"fetch: impostor fetch median {median(fetch['fetch']):.3f} s, cache get median "
                f"{median(fetch['cache']):.3f} s, nginx + curl median {median(fetch['curl']):.3f} s, "
                f"curl from the farm's HTTP median {median(fetch['farm_http']):.3f} s")
        batch = None
        if self.a.batch_assets > 0:
            batch = self.batch_fetch()
            log(f"batch: bake-batch median {median(batch['batch']):.3f} s, nginx + curl median "
                f"{median(batch['curl']):.3f} s")
        self.stop_farm()
        if self.a.fetch_only:
            rows = (self.fetch_rows(fetch) if fetch else []) + (self.batch_rows(batch) if batch else [])
            print("\n".join(["", "| figure | value | note |", "|---|---|---|"] + rows), flush=True)
            return

        iso = self.isolated_load()
        log(f"isolated load: in process {iso['in_process']:.3f} s; "
            + ", ".join(f"{k} / in-process {v:.2f}x" for k, v in iso["ratios"]))
        load1 = os.getloadavg()
        self.report(n, cold, warm, inproc, fetch, iso, load0, load1, batch, blender)

    def fetch_rows(self, fetch):
        fm, cm = median(fetch["fetch"]), median(fetch["curl"])
        return [
            f"| `impostor fetch` of the result (median of {len(fetch['fetch'])}) | {fm:.3f} s "
            f"({span(fetch['fetch'], 3)}) "
            f"| {fetch['files']} files, {fetch['mb']:.1f} MB, fresh --out each time; CPU s: CLI "
            f"{median(fetch['fetch_cpu']):.3f} + server {median(fetch['server_cpu'] or [0]):.3f} |",
            f"| nginx + curl, same files, one connection (median of {len(fetch['curl'])}) | {cm:.3f} s "
            f"({span(fetch['curl'], 3)}) | alternating pairs; CPU s: curl {median(fetch['curl_cpu']):.3f} |",
            f"| **fetch / nginx + curl** | **{fm / cm:.2f}×** | target ≤ 1.25 |",
            f"| `impostor cache get` (Cache::Get) into a fresh cache (median of {len(fetch['cache'])}) | "
            f"{median(fetch['cache']):.3f} s ({span(fetch['cache'], 3)}) | same runs; CPU s: CLI "
            f"{median(fetch['cache_cpu']):.3f} |",
            f"| **Cache::Get / nginx + curl** | **{median(fetch['cache']) / cm:.2f}×** | target ≤ 1.25 |",
            f"| `impostor fetch --farm-http` (median of {len(fetch['fetch_http'])}) | "
            f"{median(fetch['fetch_http']):.3f} s ({span(fetch['fetch_http'], 3)}) | large files from the farm's "
            f"HTTP front end, small ones in one BatchReadBlobs; CPU s: CLI {median(fetch['fetch_http_cpu']):.3f} + "
            f"server {median(fetch['http_server_cpu'] or [0]):.3f} |",
            f"| **fetch --farm-http / nginx + curl** | **{median(fetch['fetch_http']) / cm:.2f}×** | target ≤ 1.25 |",
            f"| `impostor cache get --farm-http` (median of {len(fetch['cache_http'])}) | "
            f"{median(fetch['cache_http']):.3f} s ({span(fetch['cache_http'], 3)}) | CPU s: CLI "
            f"{median(fetch['cache_http_cpu']):.3f} |",
            f"| **Cache::Get --farm-http / nginx + curl** | **{median(fetch['cache_http']) / cm:.2f}×** | "
            f"target ≤ 1.25 |",
            f"| curl from the farm's HTTP front end (median of {len(fetch['farm_http'])}) | "
            f"{median(fetch['farm_http']):.3f} s ({span(fetch['farm_http'], 3)}) | same files, one connection, "
            f"`/api/v1/results/KEY/files/NAME` with a token; {median(fetch['farm_http']) / cm:.2f}× nginx |",
        ]

    def report(self, n, cold, warm, inproc, fetch, iso, load0, load1, batch=None, blender=None):
        e2e = [b["wall"] for b in warm]
        ip = [r[1]["wall"] for r in inproc]
        ip_first = [r[0]["wall"] for r in inproc]
        ratio = median(e2e) / median(ip)
        cpus = [b["cpu"] for b in warm if b["cpu"]]
        ip_cpu = median([r[1]["cpu"] for r in inproc])
        lines = [
            "",
            f"## e2e_bench: {self.model.name}, {LAYOUT} {FRAMES}×{FRAMES}, {RESOLUTION} px, on {self.device}",
            f"({os.cpu_count()} CPUs; 1-minute load average {load0[0]:.2f} at the start, "
            f"{min(LOADS + [load1[0]]):.2f}–{max(LOADS + [load1[0]]):.2f} at the steps, {load1[0]:.2f} at the end)",
            "",
            "| figure | value | note |",
            "|---|---|---|",
            f"| end to end, first bake on a fresh farm (cold) | {cold['wall']:.2f} s | `impostor bake` wall; the "
            f"worker's own bake {cold['farm']['total']:.2f} s, submit to lease {cold['farm']['lease_latency']:.2f} s |",
            f"| end to end, warm (median of {n}) | **{median(e2e):.2f} s** ({span(e2e)}) | same running farm, "
            f"result purged before each |",
            f"| in process, `bake_stages` (median of {n}) | **{median(ip):.2f} s** ({span(ip)}) | second bake of "
            f"each process, interleaved with the warm bakes; first bake of a process {median(ip_first):.2f} s |",
            f"| **end to end / in process** (warm) | **{ratio:.2f}×** | target ≤ 1.15 |",
            f"| cold / warm end to end | {cold['wall'] / median(e2e):.2f}× | |",
        ]
        if cpus:
            tot = [c["client"] + c["server"] + c["worker"] for c in cpus]
            lines.append(
                f"| CPU s per warm bake: end to end / in process | {median(tot):.2f} / {ip_cpu:.2f} s = "
                f"{median(tot) / ip_cpu:.2f}× | client {median([c['client'] for c in cpus]):.2f} + server "
                f"{median([c['server'] for c in cpus]):.2f} + worker {median([c['worker'] for c in cpus]):.2f} "
                f"(medians); less noisy than wall on a shared machine |")
        lines += [
            f"| isolated / in-process load (`isolated_load_bench`) | **{iso['ratios'][-1][1]:.2f}×** "
            f"({iso['ratios'][-1][0]}; in process {iso['in_process']:.3f} s) | target ≤ 1.15"
            + "".join(f"; {k}: {v:.2f}×" for k, v in iso["ratios"][:-1]) + " |",
            *(e2e_blender.rows(blender, median(e2e)) if blender else []),
            *(self.fetch_rows(fetch) if fetch else []),
            *(self.batch_rows(batch) if batch else []),
            "",
            f"Where the warm bakes' time goes: the farm's `/metrics` (impostor_bake_stage_seconds, "
            f"impostor_bake_seconds) summed over the {n} warm bakes, per bake, beside `bake_stages`' recorded stages "
            f"(mean of the same {n} runs):",
            "",
            f"| stage | farm, sum of {n} | farm per bake | in process per bake | farm − in process |",
            "|---|---|---|---|---|",
        ]
        farm_sum = {k: sum(b["farm"][k] for b in warm) for k in STAGES + ["total"]}
        ip_mean = {k: statistics.mean(r[1][k] for r in inproc) for k in ["load", "render", "readback", "encode",
                                                                          "wall"]}
        ip_mean["quality"] = statistics.mean(r[1].get("quality", 0.0) for r in inproc)

        def row(name, fsum, ipv):
            per = fsum / n
            ip_cell = "–" if ipv is None else f"{ipv:.2f}"
            diff = f"{per - (ipv or 0.0):+.2f}"
            lines.append(f"| {name} | {fsum:.2f} | {per:.2f} | {ip_cell} | {diff} |")

        row("download (inputs to the worker)", farm_sum["download"], None)
        row("load", farm_sum["load"], ip_mean["load"])
        row("render", farm_sum["render"], ip_mean["render"])
        row("readback", farm_sum["readback"], ip_mean["readback"])
        row("encode (beside the quality pass)", farm_sum["encode"], ip_mean["encode"])
        row("store (maps uploaded to the server)", farm_sum["store"], None)
        ip_rest = ip_mean["wall"] - sum(ip_mean[k] for k in ["load", "render", "readback", "encode"])
        row("quality pass and the rest (total − stages)", farm_sum["total"] - sum(farm_sum[s] for s in STAGES),
            ip_rest)
        row("**the worker's bake** (impostor_bake_seconds)", farm_sum["total"], ip_mean["wall"])
        outside = sum(b["wall"] - b["farm"]["total"] for b in warm)
        row("outside the worker (CLI: check, submit, lease, result download)", outside, None)
        row("**end to end** (CLI wall)", sum(e2e), ip_mean["wall"])
        lines += [
            "",
            f"(in process: the quality pass alone {ip_mean['quality']:.2f} s per bake, overlapping encode; the "
            f"farm does not export it apart.)",
            "",
            f"isolated_load_bench on {self.model.name}:",
            "",
            iso["header"],
            "|" + "---|" * (iso["header"].count("|") - 1),
            iso["row"],
        ]
        print("\n".join(lines), flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--build", required=True)
    p.add_argument("--work", required=True)
    p.add_argument("--model", required=True)
    p.add_argument("--nginx", required=True)
    p.add_argument("--warm", type=int, default=3)
    p.add_argument("--fetch-pairs", type=int, default=7)
    p.add_argument("--fetch-only", action="store_true")
    p.add_argument("--batch-assets", type=int, default=13)
    p.add_argument("--blender", action="store_true")
    p.add_argument("--blender-views", type=int, default=0)
    a = p.parse_args()
    bench = Bench(a)
    step_logs = bench.logs
    try:
        bench.main()
    except BenchError as e:
        print(f"e2e_bench: FAILED ({e})", file=sys.stderr)
        if bench.server is not None or (step_logs / "server.err").exists():
            print(f"  last lines of the server's log:\n{tail(step_logs / 'server.err')}", file=sys.stderr)
        try:
            bench.stop_farm()
        except Exception:
            pass
        return 1
    except KeyboardInterrupt:
        print("e2e_bench: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # a bug here, or a tool printing what it never did
        import traceback
        traceback.print_exc()
        print(f"e2e_bench: FAILED (internal error: {e!r})", file=sys.stderr)
        return 1
    finally:
        if bench.server is not None:
            try:
                bench.stop_farm()
            except Exception:
                pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
