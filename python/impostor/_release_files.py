"""Files on disk for impostor.release: the umask, a verified copy into place
and an atomic write (a temporary file in the target's folder, fsynced and
renamed), so that nothing unverified ever lands under its final name.
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path
from typing import Union


# ---------------------------------------------------------------------------
# Files on disk


def _umask() -> int:
    """The process's umask, read from /proc without changing it (Linux);
    elsewhere set and restored."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _unlink_quietly(path: Union[str, Path]) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def _file_matches(path: Path, sha256: str, size: int) -> bool:
    """True when `path` is a plain file holding exactly these bytes."""
    try:
        if not path.is_file() or path.stat().st_size != size:
            return False
        digest = hashlib.sha256()
        with open(path, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                digest.update(chunk)
        return digest.hexdigest() == sha256
    except OSError:
        return False


def _write_atomically(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(data)
            out.flush()
            os.fsync(out.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        _unlink_quietly(tmp)
        raise


def _install_copy(source: Path, target: Path, sha256: str, size: int) -> bool:
    """Copies `source` to `target` by a temporary file in target's folder,
    fsynced and renamed, hashing as it copies: False (target untouched) when
    the bytes are not the digest's."""
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=target.parent)
    try:
        digest = hashlib.sha256()
        copied = 0
        with os.fdopen(fd, "wb") as out, open(source, "rb") as src:
            for chunk in iter(lambda: src.read(1 << 20), b""):
                digest.update(chunk)
                copied += len(chunk)
                out.write(chunk)
            out.flush()
            os.fsync(out.fileno())
        if copied != size or digest.hexdigest() != sha256:
            _unlink_quietly(tmp)
            return False
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, target)
        return True
    except BaseException:
        _unlink_quietly(tmp)
        raise

