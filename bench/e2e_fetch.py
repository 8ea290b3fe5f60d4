"""Step 4 of bench/e2e_bench.sh: `impostor fetch`, `impostor cache get`, the Python
client's `Client.fetch` (when built) and
`impostor bake-batch` of real results, each over gRPC alone and with the
farm's HTTP front end (--farm-http), against nginx + curl serving the same
files, in rotated rounds. Mixed into e2e_bench.py's Bench (it uses the
bench's run, fresh, token and farm addresses); not run on its own."""
import json
import os
import signal
import subprocess
import time
import urllib.parse
from pathlib import Path

from e2e_errors import BenchError
from e2e_util import LAYOUT, free_port, log, median, proc_cpu, span, tail


class FetchSteps:
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

    def python_client(self):
        """(interpreter, env) that import the built Python client
        (BUILD/python, copied by e2e_bench.sh), or None: its rows are then
        left out. Debian's /usr/bin/python3 first, as CTest runs it (it has
        python3-grpcio)."""
        package = self.build / "python"
        if not (package / "impostor").is_dir():
            return None
        interpreter = "/usr/bin/python3" if Path("/usr/bin/python3").exists() else "python3"
        env = dict(self.env, PYTHONPATH=str(package), PYTHONDONTWRITEBYTECODE="1")
        probe = subprocess.run([interpreter, "-c", "import impostor"], env=env, capture_output=True, text=True)
        if probe.returncode != 0:
            log(f"fetch: the Python client's rows left out (import impostor: {probe.stderr.strip()[-200:]})")
            return None
        return interpreter, env

    def python_fetch_cmd(self, interpreter, key, out, http):
        return [interpreter, Path(__file__).resolve().parent / "e2e_pyfetch.py", key, out, self.grpc, self.token,
                f"http://{self.http}" if http else "none"]

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
        py_s, py_wall, py_http_s, py_http_wall = [], [], [], []
        clients = ["curl", "fetch", "cache", "farm-http", "fetch-http", "cache-http"]
        python = self.python_client()
        if python is not None:
            clients += ["py", "py-http"]
        orders = [clients[k:] + clients[:k] for k in range(len(clients))]
        for i in range(self.a.fetch_pairs):
            for what in orders[i % len(orders)]:
                dest = self.fresh(f"{what}-out")
                if what == "curl":
                    wall, _, cpu = self.run("curl", curl(dest), stderr=subprocess.PIPE)
                    curl_s.append(wall)
                    curl_cpu.append(cpu)
                elif what in ("py", "py-http"):
                    # impostor.Client.fetch (farm_http="none" / the front end):
                    # the process's wall, and the fetch alone as it reports it.
                    interpreter, env = python
                    wall, r, _ = self.run("Python Client.fetch",
                                          self.python_fetch_cmd(interpreter, key, dest, what == "py-http"), env=env,
                                          stderr=subprocess.PIPE)
                    if "farm_http_fetch_fallback" in r.stderr:
                        raise BenchError(what, f"fell back to gRPC:\n{r.stderr[-1500:]}")
                    (py_wall if what == "py" else py_http_wall).append(wall)
                    (py_s if what == "py" else py_http_s).append(json.loads(r.stdout.strip().splitlines()[-1])["seconds"])
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
                    if "farm_http_fallback" in r.stderr or "farm_http_fetch_fallback" in r.stderr:
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
        start = self.start_up(curl_base[0])
        return {"start": start, "files": len(files), "mb": nbytes / 1e6, "curl": curl_s, "fetch": fetch_s,
                "curl_cpu": curl_cpu,
                "fetch_cpu": fetch_cpu, "server_cpu": server_cpu, "cache": cache_s, "cache_cpu": cache_cpu,
                "farm_http": farm_s, "fetch_http": http_s, "fetch_http_cpu": http_cpu,
                "http_server_cpu": http_server_cpu, "cache_http": cache_http_s, "cache_http_cpu": cache_http_cpu,
                "py": py_s, "py_wall": py_wall, "py_http": py_http_s, "py_http_wall": py_http_wall}

    def start_up(self, curl, runs=20):
        """`impostor --version` against `curl --version`, alternated: what
        every CLI run pays before its first byte (mapping and relocating its
        shared libraries; curl's include libcurl's)."""
        times = {"impostor": [], "curl": []}
        cpus = {"impostor": [], "curl": []}
        for _ in range(runs):
            for what, cmd in (("impostor", [self.bin / "impostor", "--version"]), ("curl", [curl, "--version"])):
                wall, _, cpu = self.run(f"{what} --version", cmd, stdout=subprocess.DEVNULL)
                times[what].append(wall)
                cpus[what].append(cpu)
        return {"times": times, "cpus": cpus}

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

    def fetch_rows(self, fetch):
        fm, cm = median(fetch["fetch"]), median(fetch["curl"])
        st = fetch["start"]
        return [
            f"| `impostor --version` / `curl --version` (medians of {len(st['times']['impostor'])}, alternated) | "
            f"{median(st['times']['impostor']) * 1e3:.1f} / {median(st['times']['curl']) * 1e3:.1f} ms | every "
            f"CLI run's start; CPU {median(st['cpus']['impostor']) * 1e3:.1f} / "
            f"{median(st['cpus']['curl']) * 1e3:.1f} ms |",
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
            f"{median(fetch['fetch_http']):.3f} s ({span(fetch['fetch_http'], 3)}) | the listing and every file "
            f"from the farm's HTTP front end, no gRPC; CPU s: CLI {median(fetch['fetch_http_cpu']):.3f} + "
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
            *self.python_rows(fetch, cm),
        ]

    def python_rows(self, fetch, cm):
        """The Python client's rows, when it ran (python_client)."""
        if not fetch.get("py"):
            return []
        return [
            f"| Python `Client.fetch` over gRPC (median of {len(fetch['py'])}) | {median(fetch['py']):.3f} s "
            f"({span(fetch['py'], 3)}) | the fetch alone ({median(fetch['py']) / cm:.2f}× nginx + curl); the "
            f"process, interpreter and imports included, {median(fetch['py_wall']):.3f} s |",
            f"| Python `Client.fetch` with `farm_http` (median of {len(fetch['py_http'])}) | "
            f"{median(fetch['py_http']):.3f} s ({span(fetch['py_http'], 3)}) | the listing and every file from the "
            f"front end ({median(fetch['py_http']) / cm:.2f}× nginx + curl); the process "
            f"{median(fetch['py_http_wall']):.3f} s |",
        ]
