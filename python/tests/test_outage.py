"""The client rides out a server outage: impostor-server is killed with
SIGKILL while a bake is being watched, and started again on the same address
and data folder; the bake finishes and its files match the manifest.

The bake is brought to a known point with events, not sleeps: the worker
pauses at its render stage while a test-controlled file exists
($IMPOSTOR_WORKER_TEST_PAUSE_FILE), and the progress callback reports that
stage. The connection events say the outage was seen and ridden out.

A retry's backoff waits on the channel (Transport.wait_for_server), so a
server restarted after a SIGKILL is found as soon as it listens, while a live
server that answers UNAVAILABLE still gets the whole backoff; and a script
that rode out an outage exits at once (no grpc thread left holding the
interpreter at exit).
"""
from __future__ import annotations

import queue
import socket
import subprocess
import sys
import threading
import time
from concurrent import futures
from pathlib import Path
from typing import Any, Dict, List, Optional

import grpc
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


def dead_address() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"127.0.0.1:{s.getsockname()[1]}"


class ConnectionTimes:
    """on_connection_change that keeps when each event came, with an event
    per kind to wait on."""

    def __init__(self) -> None:
        self.kinds: List[str] = []
        self.at: Dict[str, float] = {}
        self.seen = {"lost": threading.Event(), "regained": threading.Event()}

    def __call__(self, event: impostor.ConnectionEvent) -> None:
        self.kinds.append(event.kind)
        self.at.setdefault(event.kind, time.monotonic())
        self.seen[event.kind].set()


# How long the killed server stays away before it is started again: long
# enough that the channel is in TRANSIENT_FAILURE with its reconnect backoff
# grown, as after any real restart; part of the scenario, not a wait for
# something to happen.
OUTAGE_S = 1.0
# The client must answer again within this many seconds of the restarted
# server listening. Before retries waited on the channel, nothing drove its
# reconnection while every call slept in its backoff (only gRPC's backup
# poller, every 5 s): it took 3.8-4.1 s here (4.8-10 s with a dead second
# address); now it is the channel's own reconnect backoff, 0.03-0.9 s.
BACK_WITHIN_S = 2.5


@pytest.mark.parametrize("second_address", [False, True], ids=["one address", "and a dead one"])
def test_a_restarted_server_is_found_as_soon_as_it_listens(tmp_path: Path, second_address: bool) -> None:
    server = FarmServer(tmp_path / "data", local_workers=0)
    try:
        times = ConnectionTimes()
        target = f"{server.address},{dead_address()}" if second_address else server.address
        with impostor.Client(target, max_outage_seconds=60, on_connection_change=times) as client:
            server.kill9()
            outcome: "queue.Queue[BaseException]" = queue.Queue()

            def call() -> None:
                try:
                    client.get_job("no-such-job")
                except BaseException as e:  # handed to the test thread
                    outcome.put(e)

            caller = threading.Thread(target=call)
            caller.start()
            assert times.seen["lost"].wait(STEP_DEADLINE_S), "the call never saw the server go"
            time.sleep(OUTAGE_S)  # the outage (see OUTAGE_S)
            server.restart()
            listening = time.monotonic()
            assert times.seen["regained"].wait(STEP_DEADLINE_S), "the call never found the restarted server"
            caller.join(STEP_DEADLINE_S)
            assert not caller.is_alive()
            # The server's answer to the retried call: no such job.
            error = outcome.get_nowait()
            assert isinstance(error, impostor.ImpostorError) and error.code == grpc.StatusCode.NOT_FOUND, error
            assert times.kinds == ["lost", "regained"], times.kinds
            back = times.at["regained"] - listening
            assert back < BACK_WITHIN_S, f"the client answered again {back:.2f} s after the server listened"
    finally:
        server.stop()


# A script that uses the Client and lives through an outage: prints
# "connected", waits for a line on stdin (the server is killed by then),
# calls GetJob, which rides out the outage (printing "lost"), prints the
# outcome and returns without closing the Client.
_SCRIPT = """
import sys
import impostor
seen = set()
def changed(event):
    if event.kind not in seen:
        seen.add(event.kind)
        print(event.kind, flush=True)
client = impostor.Client(sys.argv[1], max_outage_seconds=float(sys.argv[2]), on_connection_change=changed)
print("connected", flush=True)
sys.stdin.readline()
try:
    client.get_job("no-such-job")
except impostor.ImpostorError as e:
    print("answered", e.code.name, flush=True)
"""


@pytest.mark.parametrize("server_back", [True, False], ids=["server back", "budget spent"])
def test_a_script_exits_at_once_after_an_outage(tmp_path: Path, server_back: bool) -> None:
    """Whether the server came back or the call gave up, nothing (a subscribed
    channel, grpc's connectivity thread) keeps the interpreter from exiting."""
    server = FarmServer(tmp_path / "data", local_workers=0)
    script = subprocess.Popen(
        [sys.executable, "-c", _SCRIPT, server.address, "60" if server_back else "1"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        assert script.stdin is not None and script.stdout is not None
        lines: "queue.Queue[str]" = queue.Queue()

        def pump() -> None:
            for line in script.stdout:  # type: ignore[union-attr]
                lines.put(line.strip())
            lines.put("")

        threading.Thread(target=pump, daemon=True).start()
        assert lines.get(timeout=STEP_DEADLINE_S) == "connected"
        server.kill9()
        script.stdin.write("go\n")
        script.stdin.flush()
        assert lines.get(timeout=STEP_DEADLINE_S) == "lost"
        if server_back:
            server.restart()
            assert lines.get(timeout=STEP_DEADLINE_S) == "regained"
        assert lines.get(timeout=STEP_DEADLINE_S) == ("answered NOT_FOUND" if server_back else "answered UNAVAILABLE")
        # Its last statement has run; exiting takes no grpc timeout.
        try:
            rc = script.wait(timeout=30)
        except subprocess.TimeoutExpired:
            pytest.fail("the script hung at exit after its last statement")
        assert rc == 0, script.stderr.read() if script.stderr else ""
    finally:
        if script.poll() is None:
            script.kill()
            script.wait()
        server.stop()


class _AnswersUnavailable(grpc.GenericRpcHandler):
    """A live server that is healthy but answers every other call with
    UNAVAILABLE (as one that sheds load does), noting when each came."""

    def __init__(self) -> None:
        self.arrivals: List[float] = []

    def service(self, handler_call_details: Any) -> Optional[grpc.RpcMethodHandler]:
        if handler_call_details.method == "/grpc.health.v1.Health/Check":
            return grpc.unary_unary_rpc_method_handler(lambda request, context: b"\x08\x01")  # SERVING

        def refuse(request: bytes, context: grpc.ServicerContext) -> bytes:
            self.arrivals.append(time.monotonic())
            context.abort(grpc.StatusCode.UNAVAILABLE, "shedding load")
            return b""

        return grpc.unary_unary_rpc_method_handler(refuse)


@pytest.mark.parametrize("max_outage_seconds", [0, 1.0])
def test_a_live_server_answering_unavailable_gets_the_whole_backoff(max_outage_seconds: float) -> None:
    """The channel is connected, so waiting on it would end the backoff at
    once: the tries must still come the backoff apart (100 ms, 200 ms, ...
    minus up to 20%), lower bounds that a loaded machine only lengthens.
    With an outage budget (1 s) the first three tries all fall within it."""
    handler = _AnswersUnavailable()
    server = grpc.server(futures.ThreadPoolExecutor(max_workers=2), handlers=[handler])
    port = server.add_insecure_port("127.0.0.1:0")
    server.start()
    try:
        with impostor.Client(f"127.0.0.1:{port}", max_attempts=4, max_outage_seconds=max_outage_seconds) as client:
            with pytest.raises(impostor.ImpostorError) as caught:
                client.get_job("any")
        assert caught.value.code == grpc.StatusCode.UNAVAILABLE and "shedding load" in caught.value.message
        gaps = [b - a for a, b in zip(handler.arrivals, handler.arrivals[1:])]
        assert len(gaps) >= 3, handler.arrivals
        for i, gap in enumerate(gaps[:3]):
            backoff_at_least = 0.1 * 2**i * 0.8
            assert gap >= backoff_at_least, (
                f"try {i + 2} came {gap:.3f} s after try {i + 1}; {len(handler.arrivals)} tries, gaps {gaps[:4]}"
            )
    finally:
        server.stop(None)
