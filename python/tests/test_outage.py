"""The client rides out a server outage: impostor-server is killed with
SIGKILL while a bake is being watched, and started again on the same address
and data folder; the bake finishes and its files match the manifest.

The bake is brought to a known point with events, not sleeps: the worker
pauses at its render stage while a test-controlled file exists
($IMPOSTOR_WORKER_TEST_PAUSE_FILE), and the progress callback reports that
stage. The connection events say the outage was seen and ridden out.
"""
from __future__ import annotations

from pathlib import Path
from typing import List

import pytest

import impostor
from conftest import BakeInBackground, sha256_file
from farm_process import FarmServer

TREE = "vegetation/TreeLowPoly_RicardoSanchez/scene.gltf"
# A bound on one step on a loaded machine; reaching it is a failure (a hang).
STEP_DEADLINE_S = 120


def test_bake_survives_a_killed_and_restarted_server(assets: Path, tmp_path: Path) -> None:
    pause = tmp_path / "pause"
    pause.write_text("pause")
    # The restarted server re-leases the killed one's job once its lease
    # expires (5 s); the orphaned worker may deliver first. Either is fine.
    server = FarmServer(tmp_path / "data", extra_args=["--lease-timeout-s=5"],
                        env={"IMPOSTOR_WORKER_TEST_PAUSE_FILE": str(pause)})
    try:
        events: List[impostor.ConnectionEvent] = []
        client = impostor.Client(server.address, max_outage_seconds=120, on_connection_change=events.append)
        bake = BakeInBackground(client, assets / TREE, tmp_path / "out", frames=4, resolution=128, quality_views=0)
        assert bake.at_render.wait(STEP_DEADLINE_S), "the bake never reached the worker's render stage"

        server.kill9()
        server.restart()
        pause.unlink()  # every worker may finish now

        result: impostor.BakeResult = bake.result(STEP_DEADLINE_S * 2)
        assert result.job.state == "succeeded"
        for m in result.manifest["maps"]:
            assert sha256_file(result.dir / m["file"]) == m["digest"]["hash"], m["file"]
        # The outage was noticed and ridden out, once each.
        assert [e.kind for e in events] == ["lost", "regained"], events
        assert events[0].error is not None and events[0].error.code.name == "UNAVAILABLE"
        assert events[1].outage_seconds > 0
        client.close()
    finally:
        server.stop()


def test_outage_budget_ends_in_unavailable(assets: Path, tmp_path: Path) -> None:
    """With max_outage_seconds spent, a call gives up with the UNAVAILABLE it saw."""
    server = FarmServer(tmp_path / "data", local_workers=0)
    try:
        events: List[impostor.ConnectionEvent] = []
        client = impostor.Client(server.address, max_outage_seconds=1, max_attempts=2,
                                 on_connection_change=events.append)
        server.kill9()
        with pytest.raises(impostor.ImpostorError) as caught:
            client.get_job("any")
        assert caught.value.code.name == "UNAVAILABLE" and caught.value.rpc == "GetJob"
        assert [e.kind for e in events] == ["lost"]
        client.close()
    finally:
        server.stop()
