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
import signal
import statistics
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from pathlib import Path

import e2e_blender
from e2e_errors import BenchError
from e2e_fetch import FetchSteps
from e2e_util import FRAMES, LAYOUT, LOADS, RESOLUTION, children_cpu, log, median, proc_cpu, span, tail

# Stages the worker reports in BakeTimings and /metrics exports as
# impostor_bake_stage_seconds{stage=...} (server/metrics/farm_metrics.cc).
STAGES = ["download", "load", "render", "readback", "encode", "store"]
# Worker token name of --local-workers on a server with its own SQLite store
# (LocalWorkerTokenName in server/commands/token_command.cc).
LOCAL_WORKER_TOKEN = "local-workers"


class Bench(FetchSteps):
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
