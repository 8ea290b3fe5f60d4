"""A throwaway PostgreSQL server for pytest, the Python twin of
tests/support/postgres_instance.h: `initdb` into a new temporary directory,
`pg_ctl -w start` (which returns once the server accepts connections) on a
Unix socket only, stopped and removed by stop(). As root every binary runs as
the `postgres` user (PostgreSQL refuses root). Binaries: $IMPOSTOR_PG_BIN or
Debian's /usr/lib/postgresql/15/bin; without them `available()` is False."""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import List


def _bin_dir() -> Path:
    return Path(os.environ.get("IMPOSTOR_PG_BIN", "/usr/lib/postgresql/15/bin"))


def available() -> bool:
    return (_bin_dir() / "initdb").exists() and (_bin_dir() / "pg_ctl").exists()


class PostgresServer:
    def __init__(self) -> None:
        # Under /tmp itself: pytest's tmp_path lies in a root-only folder the
        # postgres user cannot enter.
        self.dir = Path(tempfile.mkdtemp(prefix="impostor_pytest_pg_"))
        self._prefix: List[str] = []
        if os.geteuid() == 0:
            self._prefix = ["runuser", "-u", "postgres", "--"]
            shutil.chown(self.dir, "postgres", "postgres")
        self._data = self.dir / "data"
        self._run("initdb", "-D", str(self._data), "-U", "postgres", "-E", "UTF8", "--no-sync",
                  "--auth-local=trust", "--auth-host=trust")
        self._run("pg_ctl", "-D", str(self._data), "-l", str(self.dir / "server.log"), "-w", "-t", "60", "-o",
                  f"-c listen_addresses='' -k {self.dir} -c fsync=off -c max_connections=200", "start")

    def _run(self, tool: str, *args: str) -> None:
        result = subprocess.run([*self._prefix, str(_bin_dir() / tool), *args], capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(f"{tool} failed ({result.returncode}): {result.stdout}{result.stderr}")

    def url(self, database: str = "postgres") -> str:
        return f"postgresql://postgres@/{database}?host={self.dir}"

    def stop(self) -> None:
        try:
            self._run("pg_ctl", "-D", str(self._data), "-w", "-m", "fast", "stop")
        finally:
            shutil.rmtree(self.dir, ignore_errors=True)
