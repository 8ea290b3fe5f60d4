"""One "Bake selected": the selection exported as .glb (main thread), the
farm round trip through the Python client (a worker thread: Blender's UI
keeps running), then the result imported (main thread again).

Thread-safety: the worker thread touches no bpy data; it writes the latest
state under a lock and the main thread reads it (snapshot()).
"""
from __future__ import annotations

import tempfile
import threading
from pathlib import Path
from typing import Any, Dict, Optional

import bpy


def export_selection(folder: Path) -> Path:
    """Writes the selected objects, transforms applied, to folder/selection.glb."""
    path = folder / "selection.glb"
    bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLB", use_selection=True, export_apply=True)
    return path


class BakeJob:
    """The farm side of one bake. Construct on the main thread, then run()
    (blocking) or start() (a thread); poll with snapshot(), read `result` or
    `error` once done."""

    def __init__(self, *, server: str, token_file: str, tls_ca: str, model: Path, out_dir: Path,
                 settings: Dict[str, Any]) -> None:
        self.server = server
        self.token_file = token_file
        self.tls_ca = tls_ca
        self.model = model
        self.out_dir = out_dir
        self.settings = settings
        self.result: Any = None  # impostor.BakeResult once succeeded
        self.error: Optional[BaseException] = None
        self.done = threading.Event()
        self._lock = threading.Lock()
        self._status = "connecting"  # guarded by _lock
        self._progress = 0.0  # guarded by _lock
        self._job_id = ""  # guarded by _lock
        self._client: Any = None
        self._thread: Optional[threading.Thread] = None

    def _set(self, status: str, progress: Optional[float] = None) -> None:
        with self._lock:
            self._status = status
            if progress is not None:
                self._progress = progress

    def snapshot(self) -> "tuple[str, float]":
        """(one line for the status bar, fraction done)."""
        with self._lock:
            return self._status, self._progress

    def run(self) -> None:
        """The whole round trip on the calling thread; sets result or error."""
        import impostor  # importable once deps.ensure_client() said so

        try:
            self._client = impostor.Client(
                self.server, token_file=self.token_file or None, tls_ca=self.tls_ca or None,
                on_connection_change=lambda e: self._set(
                    "farm unreachable, retrying" if e.kind == "lost" else "farm back"),
            )
            with self._client as client:
                self._set("uploading")
                submitted = client.submit(self.model, **self.settings)
                with self._lock:
                    self._job_id = submitted.job_id

                def on_update(u: "impostor.JobUpdate") -> None:
                    what = u.stage if u.state == "running" and u.stage else u.state
                    self._set(f"{what} {u.progress:.0%}" + (" (cached)" if u.cached else ""), u.progress)

                job = client.watch(submitted.job_id, on_update)
                if job.state != "succeeded":
                    raise impostor.ImpostorError(
                        impostor.errors.status_code_from_int(job.error_code or 2),
                        f"bake {job.state}: {job.error_message}", job_id=job.job_id, cache_key=job.cache_key)
                self._set("downloading", 1.0)
                fetched = client.fetch(job.cache_key, self.out_dir)
                self.result = impostor.BakeResult(job.cache_key, job, submitted, fetched)
                self._set("done", 1.0)
        except BaseException as e:  # reported on the main thread
            self.error = e
        finally:
            self.done.set()

    def start(self) -> None:
        self._thread = threading.Thread(target=self.run, name="impostor-bake", daemon=True)
        self._thread.start()

    def cancel(self) -> None:
        """Asks the farm to cancel the job (the watch then ends as cancelled)."""
        with self._lock:
            job_id = self._job_id
        if job_id and self._client is not None:
            try:
                self._client.cancel(job_id)
            except Exception as e:  # the thread reports the outcome
                self._set(f"cancel failed: {e}")


def default_out_dir(settings_dir: str) -> Path:
    if settings_dir:
        folder = Path(bpy.path.abspath(settings_dir))
        folder.mkdir(parents=True, exist_ok=True)
        return Path(tempfile.mkdtemp(prefix="impostor-", dir=folder))
    return Path(tempfile.mkdtemp(prefix="impostor-result-"))
