"""A real impostor-server (with --local-workers) for tests: started on port 0,
restarted on the same address and data folder, killed with SIGKILL.

Readiness is an event, never a sleep: the server prints "impostor-server
listening on HOST:PORT" on stdout once its port is bound (the same moment it
writes --port-file), and a reader thread hands that line over; with
`http_listen` (--http-listen) it then prints "impostor-server http listening
on HOST:PORT" for its HTTP front end (docs/http_api.md), waited for too;
`http_advertise` (--http-advertise, with http_listen) is the base URL its
GetResult answers name as its front end. Each server
runs in its own session, so teardown also ends local workers a SIGKILLed
server left behind.

A server and its workers get a TMPDIR of their own next to the data folder
(DATA.tmp), unless the caller's env names one: a local worker's scratch
folder ($TMPDIR/impostor-worker-<pid>) is removed by the worker, and
stop() SIGKILLs it first, so it would otherwise stay in /tmp. Under CTest
all of it lies in the test's temporary root (tests/run_in_temp_root.py).
"""
from __future__ import annotations

import os
import queue
import signal
import subprocess
import threading
from pathlib import Path
from typing import Dict, List, Optional, Sequence

# Generous bound for one start on a loaded 2-core machine; reaching it is a
# failure (a hang), not a timing measurement.
START_DEADLINE_S = 90


def bin_dir() -> Path:
    value = os.environ.get("IMPOSTOR_BIN_DIR")
    if not value:
        raise RuntimeError("IMPOSTOR_BIN_DIR is not set (ctest sets it to the folder of impostor-server)")
    return Path(value)


def assets_dir() -> Path:
    value = os.environ.get("IMPOSTOR_TEST_ASSETS_DIR")
    if not value:
        raise RuntimeError("IMPOSTOR_TEST_ASSETS_DIR is not set (ctest sets it to ../shared/assets)")
    return Path(value)


class FarmServer:
    """impostor-server with `local_workers` workers on `data_dir`."""

    def __init__(
        self,
        data_dir: Path,
        *,
        local_workers: int = 1,
        extra_args: Sequence[str] = (),
        env: Optional[Dict[str, str]] = None,
        http_listen: Optional[str] = None,
        http_advertise: Optional[str] = None,
    ) -> None:
        self.data_dir = data_dir
        self.local_workers = local_workers
        self.extra_args = list(extra_args)
        self.tmp_dir = data_dir.parent / f"{data_dir.name}.tmp"
        self.env = dict(os.environ, TMPDIR=str(self.tmp_dir))
        self.env.update(env or {})
        self.tmp_dir.mkdir(parents=True, exist_ok=True)
        self.listen = "127.0.0.1:0"
        self.address = ""
        # --http-listen (HOST:PORT, port 0 = any); None: no HTTP front end.
        self.http_listen = http_listen
        self.http_address = ""  # HOST:PORT the front end listens on
        # --http-advertise (a base URL, known before the start); None: none.
        self.http_advertise = http_advertise
        self.log_path = data_dir.parent / f"{data_dir.name}.server.log"
        self._process: Optional[subprocess.Popen[bytes]] = None
        self._sessions: List[int] = []  # process groups to end at stop()
        self.start()

    def start(self) -> None:
        port_file = self.data_dir.parent / f"{self.data_dir.name}.port"
        argv = [
            str(bin_dir() / "impostor-server"),
            f"--listen={self.listen}",
            f"--data={self.data_dir}",
            f"--local-workers={self.local_workers}",
            f"--port-file={port_file}",
            "--log-level=info",
            *([f"--http-listen={self.http_listen}"] if self.http_listen is not None else []),
            *([f"--http-advertise={self.http_advertise}"] if self.http_advertise is not None else []),
            *self.extra_args,
        ]
        log = open(self.log_path, "ab")
        self._process = subprocess.Popen(
            argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=log,
            env=self.env, start_new_session=True,
        )
        log.close()
        self._sessions.append(self._process.pid)
        lines: "queue.Queue[Optional[str]]" = queue.Queue()
        stdout = self._process.stdout
        assert stdout is not None

        def pump() -> None:  # also keeps the pipe drained for the server's life
            for raw in stdout:
                lines.put(raw.decode(errors="replace"))
            lines.put(None)

        threading.Thread(target=pump, daemon=True).start()
        while True:
            try:
                line = lines.get(timeout=START_DEADLINE_S)
            except queue.Empty:
                raise RuntimeError(f"impostor-server printed no 'listening on' line within {START_DEADLINE_S} s; "
                                   f"log: {self.log_path}\n{self.log_tail()}") from None
            if line is None:
                raise RuntimeError(f"impostor-server exited ({self._process.wait()}) before listening; "
                                   f"log: {self.log_path}\n{self.log_tail()}")
            if "http listening on" in line:
                # Printed after the gRPC line (server/main.cc).
                self.http_address = line.strip().rsplit(" ", 1)[-1]
                break
            if "listening on" in line:
                self.address = line.strip().rsplit(" ", 1)[-1]
                if self.http_listen is None:
                    break
        # Restarts keep the addresses clients know.
        self.listen = self.address
        if self.http_listen is not None:
            self.http_listen = self.http_address

    @property
    def port(self) -> int:
        return int(self.address.rsplit(":", 1)[1])

    @property
    def http_url(self) -> str:
        """The HTTP front end's base URL, http://HOST:PORT (with http_listen)."""
        assert self.http_address, "started without http_listen"
        return f"http://{self.http_address}"

    def kill9(self) -> None:
        """SIGKILL to the server alone (its local workers live on, orphaned)."""
        assert self._process is not None
        self._process.kill()
        self._process.wait()

    def freeze(self, frozen: bool = True) -> None:
        """SIGSTOP (or SIGCONT) to the server alone: its port still accepts
        connections (the kernel does that), but nothing answers."""
        assert self._process is not None
        self._process.send_signal(signal.SIGSTOP if frozen else signal.SIGCONT)
        # A signal takes effect asynchronously: without waiting, a call made
        # at once could still be answered (the failover test saw it 1 in 8).
        # waitpid reports the stop (or the continue) without reaping.
        os.waitpid(self._process.pid, os.WUNTRACED if frozen else os.WCONTINUED)

    def restart(self) -> None:
        """Starts the server again on the same address and data folder."""
        self.start()

    def stop(self) -> None:
        """Ends every process this server started, orphans included."""
        for pgid in self._sessions:
            try:
                os.killpg(pgid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        if self._process is not None:
            self._process.wait()
        self._sessions.clear()

    def log_tail(self, lines: int = 30) -> str:
        try:
            return "\n".join(self.log_path.read_text(errors="replace").splitlines()[-lines:])
        except OSError:
            return ""
