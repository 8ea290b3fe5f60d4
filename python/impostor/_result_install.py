"""Installing a baked result into a folder, whichever road its bytes take
(gRPC, _blobs; the farm's HTTP front end, _farm_http): the Python twin of
InstallResultFiles and AtomicFileWriter in the C++ SDK
(client/transfer/result_fetch.h, client/base/atomic_file.h).

Every file the result lacks is written into a temporary file beside its
name (".NAME.XXXX.part") and verified; once all are there they are synced
and renamed in order, the maps first and manifest.json last, so a
manifest.json on disk means its files are complete. When any file fails,
no file of the result is renamed into the folder and the temporary files
are removed. Files already there with the right digest are kept.

A large staged file starts its flush to disk as soon as the road moves on
to the next file (EarlySync, the twin of client/base/early_sync.h), so the
one sync before the renames finds little left to wait for.
"""
from __future__ import annotations

import errno
import json
import os
import tempfile
import threading
import time
from pathlib import Path
from typing import Callable, List, Optional, Set, Tuple

import grpc

from ._mesh_files import digest_file
from ._release_files import _umask, _unlink_quietly
from .errors import ImpostorError
from .results import FetchResult
from .v1 import types_pb2 as pb

MANIFEST_FILE_NAME = "manifest.json"


def local_error(what: str, path: Path, error: OSError) -> ImpostorError:
    """INTERNAL "<what> <path>: <why>": trouble with this machine's own files,
    the same whichever road the bytes took (never tried on another road)."""
    why = error.strerror or str(error)
    if error.errno in (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC)):
        why += "; free space and try again"
    return ImpostorError(grpc.StatusCode.INTERNAL, f"{what} {path}: {why}")


def manifest_problem(manifest: "pb.Manifest") -> Optional[str]:
    """What is wrong with the files a result's listing names, or None: only
    distinct plain file names (a result must never write outside its
    folder) and well-formed digests (the C++ SDK's CheckManifestFiles)."""
    names: Set[str] = {MANIFEST_FILE_NAME}
    digests = [("manifest_json", manifest.manifest_json)]
    for i, m in enumerate(manifest.maps):
        if not m.file or "/" in m.file or "\\" in m.file or m.file in (".", "..") or m.file in names:
            return f'maps[{i}].file: "{m.file}" is not a distinct plain file name'
        names.add(m.file)
        digests.append((f"maps[{i}].digest", m.digest))
    for field, d in digests:
        if len(d.hash) != 64 or any(c not in "0123456789abcdef" for c in d.hash) or d.size_bytes < 0:
            return f"{field}: malformed digest"
    return None


def already_there(path: Path, digest: "pb.Digest") -> bool:
    """True when `path` already holds exactly the blob `digest`."""
    try:
        if not path.is_file() or path.stat().st_size != digest.size_bytes:
            return False  # cheap check first
        return digest_file(path)[0] == digest.hash
    except OSError:
        return False


class StagedFile:
    """A temporary file beside `path` (".NAME.XXXX.part", in its folder, so
    the rename stays on one filesystem) that becomes `path` on commit(): the
    Python twin of AtomicFileWriter. Its errors are ImpostorError INTERNAL
    naming `path` (local_error), never OSError, so that a road reading from
    the network tells them from the network's own (a disk-full write is not
    a broken connection). seek/truncate/write make it the sink of
    _release_http's reads."""

    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            fd, self._tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
        except OSError as e:
            raise local_error("cannot write", path, e) from None
        self._file = os.fdopen(fd, "w+b")
        self._done = False
        self._synced = False  # no write since the last sync()

    def write(self, data: bytes) -> int:
        self._synced = False
        try:
            return self._file.write(data)
        except OSError as e:
            raise local_error("cannot write", self.path, e) from None

    def seek(self, offset: int, whence: int = 0) -> int:
        try:
            return self._file.seek(offset, whence)
        except OSError as e:
            raise local_error("cannot write", self.path, e) from None

    def truncate(self, size: Optional[int] = None) -> int:
        self._synced = False
        try:
            return self._file.truncate(size)
        except OSError as e:
            raise local_error("cannot write", self.path, e) from None

    def sync(self) -> None:
        if self._synced:
            return
        try:
            self._file.flush()
            os.fsync(self._file.fileno())
        except OSError as e:
            raise local_error("cannot sync", self.path, e) from None
        self._synced = True

    def hand_to(self, early_sync: "EarlySync") -> None:
        """Its bytes written so far handed to `early_sync` (a large file the
        road is done with)."""
        if self._done:
            return
        try:
            self._file.flush()
            size = os.fstat(self._file.fileno()).st_size
        except OSError as e:
            raise local_error("cannot write", self.path, e) from None
        early_sync.add(self._file.fileno(), size, self.path)

    def commit(self) -> None:
        """Synced (unless sync() was called since the last write), closed, made
        a plain file (0666 less the umask, as the CLI writes it: mkstemp
        makes 0600) and renamed to `path`."""
        self.sync()
        try:
            self._file.close()
            os.chmod(self._tmp, 0o666 & ~_umask())
            os.replace(self._tmp, self.path)
        except OSError as e:
            raise local_error(f"cannot rename {self._tmp} to", self.path, e) from None
        self._done = True

    def abort(self) -> None:
        """Removes the temporary file (a no-op after commit)."""
        if self._done:
            return
        self._done = True
        try:
            self._file.close()
        except OSError:
            pass
        _unlink_quietly(self._tmp)


class EarlySync:
    """fdatasync of a finished large file on a thread of its own, while the
    rest of the result downloads. Why: on a disk with a write cache (a VM's
    virtual disk, most SSDs) a sync waits for the flush of the bytes written
    (16 ms for a 26 MB result on the CI machine's disk, however early their
    writeback began), so the one sync at the end waited that long with
    nothing else to do. A failure is kept and raised by finish(): after a
    failed fdatasync the kernel may report the next sync of the file as a
    success although its bytes are lost."""

    MIN_BYTES = 1 << 20  # smaller files are left to the final sync
    MAX_PENDING = 8  # descriptors held at most; more are left to the final sync

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._pending: List[Tuple[int, Path]] = []
        self._busy = False
        self._stopping = False
        self._error: Optional[ImpostorError] = None
        self._thread: Optional[threading.Thread] = None
        self.synced = 0  # files synced so far (tests)

    def add(self, fd: int, size: int, path: Path) -> None:
        """Hands over the complete file open as `fd` (a duplicate is kept)."""
        if size < self.MIN_BYTES:
            return
        with self._cond:
            if self._stopping or self._error is not None or len(self._pending) >= self.MAX_PENDING:
                return
            try:
                copy = os.dup(fd)
            except OSError:
                return  # out of descriptors: the final sync covers it
            self._pending.append((copy, path))
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="impostor-early-sync", daemon=True)
                self._thread.start()
            self._cond.notify_all()

    def _run(self) -> None:
        with self._cond:
            while True:
                self._cond.wait_for(lambda: self._stopping or bool(self._pending))
                if self._stopping:
                    return
                fd, path = self._pending.pop(0)
                self._busy = True
                self._cond.release()
                error: Optional[OSError] = None
                try:
                    os.fdatasync(fd)
                except OSError as e:
                    error = e
                finally:
                    os.close(fd)
                    self._cond.acquire()
                self._busy = False
                if error is None:
                    self.synced += 1
                elif self._error is None:
                    self._error = local_error("cannot sync", path, error)
                    self._drop_pending()
                self._cond.notify_all()

    def _drop_pending(self) -> None:
        for fd, _ in self._pending:
            os.close(fd)
        self._pending.clear()

    def finish(self) -> None:
        """Waits for every file handed over; raises the first failure."""
        with self._cond:
            self._cond.wait_for(lambda: not self._pending and not self._busy)
            if self._error is not None:
                raise self._error

    def stop(self) -> None:
        """Drops what waits and waits for the sync under way."""
        with self._cond:
            self._stopping = True
            self._drop_pending()
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join()


class Staging:
    """The staged files of one install: all renamed in by commit_all(), or
    all removed by abort_all(). The roads stage one file at a time, so a
    file is complete once the next is staged: a large one is then handed to
    the early sync."""

    def __init__(self) -> None:
        self._files: List[StagedFile] = []
        self._early_sync = EarlySync()

    def stage(self, path: Path) -> StagedFile:
        if self._files:
            self._files[-1].hand_to(self._early_sync)
        staged = StagedFile(path)
        self._files.append(staged)
        return staged

    def abort_all(self) -> None:
        self._early_sync.stop()
        for f in self._files:
            f.abort()

    def commit_all(self, order: List[Path], required: List[Path]) -> None:
        """Syncs every staged file, then renames them in `order` (one sync
        for the lot; the renames after it, manifest.json last). INTERNAL,
        nothing renamed, when a `required` file was not staged."""
        by_path = {f.path: f for f in self._files}
        for path in required:
            if path not in by_path:
                raise ImpostorError(grpc.StatusCode.INTERNAL, f"{path}: not downloaded (a bug of the client)")
        self._early_sync.finish()
        for f in self._files:
            f.sync()
        for path in order:
            if path in by_path:
                by_path[path].commit()


#: A road to a result's bytes: stages each (name, path, digest) it is
#: given, verified, with Staging.stage. It raises what it raises; the
#: install then removes whatever was staged.
Road = Callable[[List[Tuple[str, Path, "pb.Digest"]], Staging], None]


def install_result(manifest: "pb.Manifest", out_dir: Path, road: Road, start: float) -> FetchResult:
    """Installs the result `manifest` lists (checked: manifest_problem) into
    `out_dir` (created if needed), the files it lacks taken by `road`.

    Raises ImpostorError: INTERNAL for local trouble (local_error; the
    folder cannot be made), or the road's own error; on any error nothing
    of the result was renamed into out_dir (a manifest.json there of
    another result has been removed: it would describe maps being
    replaced)."""
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ImpostorError(grpc.StatusCode.INTERNAL, f"cannot create directory {out_dir}: {e.strerror}") from None
    wanted = [(m.file, out_dir / m.file, m.digest) for m in manifest.maps]
    wanted.append((MANIFEST_FILE_NAME, out_dir / MANIFEST_FILE_NAME, manifest.manifest_json))
    manifest_path = out_dir / MANIFEST_FILE_NAME
    if not already_there(manifest_path, manifest.manifest_json):
        try:
            manifest_path.unlink()
        except FileNotFoundError:
            pass
        except OSError as e:
            raise local_error("cannot remove the previous", manifest_path, e) from None
    missing = [(name, path, digest) for name, path, digest in wanted if not already_there(path, digest)]
    staging = Staging()
    try:
        road(missing, staging)
        staging.commit_all([path for _, path, _ in wanted], [path for _, path, _ in missing])
    finally:
        staging.abort_all()  # what was not committed
    downloaded = sum(digest.size_bytes for _, _, digest in missing)
    reused = sum(digest.size_bytes for _, _, digest in wanted) - downloaded
    try:
        parsed = json.loads(manifest_path.read_text())
    except OSError as e:
        raise local_error("cannot read", manifest_path, e) from None
    return FetchResult(
        dir=out_dir,
        manifest_path=manifest_path,
        files=[path for _, path, _ in wanted],
        manifest=parsed,
        bytes_downloaded=downloaded,
        bytes_reused=reused,
        warnings=list(manifest.warnings),
        seconds=time.monotonic() - start,
    )
