"""The install's early sync (_result_install.EarlySync, the twin of
client/base/early_sync.h): a large staged file is synced on its own thread
once the road stages the next; small ones are left to the final sync; a
failed sync is raised, naming the file, and nothing is renamed in."""
from __future__ import annotations

import os
from pathlib import Path

import grpc
import pytest

from impostor import _result_install
from impostor.errors import ImpostorError


def test_a_large_file_is_synced_once_the_next_is_staged(tmp_path: Path) -> None:
    staging = _result_install.Staging()
    try:
        big = staging.stage(tmp_path / "albedo_alpha.png")
        big.write(b"a" * _result_install.EarlySync.MIN_BYTES)
        small = staging.stage(tmp_path / "view_00.png")  # big is complete now
        small.write(b"b" * 1000)
        last = staging.stage(tmp_path / "manifest.json")  # small: left to the final sync
        last.write(b"{}")
        staging.commit_all([tmp_path / n for n in ("albedo_alpha.png", "view_00.png", "manifest.json")], [])
        assert staging._early_sync.synced == 1
    finally:
        staging.abort_all()
    assert (tmp_path / "albedo_alpha.png").stat().st_size == _result_install.EarlySync.MIN_BYTES
    assert (tmp_path / "manifest.json").read_bytes() == b"{}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["albedo_alpha.png", "manifest.json", "view_00.png"]


def test_a_failed_early_sync_is_raised_and_nothing_is_renamed(tmp_path: Path) -> None:
    early = _result_install.EarlySync()
    read_end, write_end = os.pipe()  # fdatasync of a pipe fails (EINVAL): a disk's EIO stand-in
    try:
        early.add(read_end, 4 << 20, tmp_path / "normal_depth.png")
        with pytest.raises(ImpostorError) as failed:
            early.finish()
        assert failed.value.code == grpc.StatusCode.INTERNAL
        assert f"cannot sync {tmp_path / 'normal_depth.png'}" in failed.value.message
        # A later file does not clear it.
        with open(tmp_path / "later.bin", "wb") as later:
            later.write(b"c" * (2 << 20))
            later.flush()
            early.add(later.fileno(), 2 << 20, tmp_path / "later.bin")
            with pytest.raises(ImpostorError):
                early.finish()
        assert early.synced == 0
    finally:
        early.stop()
        os.close(read_end)
        os.close(write_end)

    # Through a Staging: the install raises it and renames nothing.
    staging = _result_install.Staging()
    broken = staging._early_sync
    r, w = os.pipe()
    try:
        staging.stage(tmp_path / "a.png").write(b"x" * 10)
        broken.add(r, 4 << 20, tmp_path / "a.png")
        with pytest.raises(ImpostorError) as raised:
            staging.commit_all([tmp_path / "a.png"], [tmp_path / "a.png"])
        assert "cannot sync" in raised.value.message
    finally:
        staging.abort_all()
        os.close(r)
        os.close(w)
    assert not (tmp_path / "a.png").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".a.png.")]


def test_stopping_with_files_waiting_closes_every_duplicate(tmp_path: Path) -> None:
    before = len(os.listdir("/proc/self/fd"))
    early = _result_install.EarlySync()
    files = []
    for i in range(12):
        f = open(tmp_path / f"f{i}.bin", "wb")
        f.write(b"d" * (1 << 20))
        f.flush()
        files.append(f)
        early.add(f.fileno(), 1 << 20, tmp_path / f"f{i}.bin")
    early.stop()  # drops what waits (at most MAX_PENDING were kept), waits for the sync under way
    for f in files:
        f.close()
    assert len(os.listdir("/proc/self/fd")) == before
