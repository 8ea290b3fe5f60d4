"""Client.fetch over the farm's HTTP front end alone (farm_http,
$IMPOSTOR_FARM_HTTP) against a real impostor-server run with --http-listen:
the listing (GET /api/v1/results/KEY/manifest) and every file from it, byte
for byte what gRPC gives, with no gRPC server reachable; a front end that
spoils the listing or a file (a fault-injecting proxy in front of the real
one) falls back to gRPC with one warning and the exact result, or, with no
gRPC either, fails naming the problem with nothing of the result installed;
local failures are not retried over gRPC; bad farm_http values.

The farm also advertises a front end (--http-advertise: a counting proxy in
front of its own): a Client given none takes the large files from it and
the rest over gRPC, a file it cannot give over ReadBlob, and gives it up
after 3 such files in a row; "none" ignores it; a refused advertisement is
one warning and gRPC."""
from __future__ import annotations

import base64
import dataclasses
import errno
import hashlib
import http.server
import logging
import os
import socket
import threading
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path
from typing import Callable, Dict, Iterator, List, Optional, Tuple

import grpc
import pytest

import impostor
from farm_process import FarmServer
from impostor import _blobs, _farm_http
from impostor.v1 import types_pb2 as pb

TREE = "vegetation/TreeLowPoly_RicardoSanchez/scene.gltf"
# Quick on the software renderer; 256 px maps stream in several pieces,
# and the quality pass's view images make many small files.
SETTINGS = dict(frames=4, resolution=256, quality_views=4)
LOGGER = "impostor.client"
# The advertised front end's tests count a file over this many bytes as
# large (no BatchReadBlobs batch carries it), in place of 1 MiB: the quick
# bake's maps are smaller than that.
LARGE = 64 << 10

# A fault: (path, status, headers, body) -> the same, as the proxy sends it.
Answer = Tuple[int, Dict[str, str], bytes]
Fault = Callable[[str, int, Dict[str, str], bytes], Answer]


@dataclasses.dataclass
class Baked:
    key: str
    files: Dict[str, bytes]  # every file of the result, as gRPC fetched it
    manifest: dict
    last_map: str  # the manifest's last map file: fetched after the others


@pytest.fixture(scope="module")
def advertised_proxy() -> Iterator["FaultyFrontEnd"]:
    """The front end the farm advertises: a proxy in front of its own,
    started first (its URL goes on the farm's command line); its upstream
    is set once the farm listens."""
    proxy = FaultyFrontEnd("")
    yield proxy
    proxy.close()


@pytest.fixture(scope="module")
def http_farm(tmp_path_factory: pytest.TempPathFactory, advertised_proxy: "FaultyFrontEnd") -> Iterator[FarmServer]:
    server = FarmServer(tmp_path_factory.mktemp("http_farm") / "data", http_listen="127.0.0.1:0",
                        http_advertise=advertised_proxy.url + "/")
    advertised_proxy.upstream = server.http_url
    yield server
    server.stop()


@pytest.fixture(scope="module")
def baked(http_farm: FarmServer, assets: Path, tmp_path_factory: pytest.TempPathFactory) -> Baked:
    with impostor.Client(http_farm.address, farm_http="none") as c:  # gRPC alone
        result = c.bake(assets / TREE, tmp_path_factory.mktemp("over_grpc"), **SETTINGS)
    files = {p.name: p.read_bytes() for p in result.files}
    assert len(files) > 5 and max(len(b) for b in files.values()) > 64 << 10, "small and streamed files"
    return Baked(result.cache_key, files, result.manifest, result.manifest["maps"][-1]["file"])


@pytest.fixture(autouse=True)
def no_farm_http_in_env(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("IMPOSTOR_FARM_HTTP", raising=False)


@pytest.fixture
def dead_address() -> Iterator[str]:
    """HOST:PORT where nothing listens (bound, never listening: refused)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        yield f"127.0.0.1:{s.getsockname()[1]}"


class FaultyFrontEnd:
    """A proxy in front of the farm's HTTP front end: answers what it answers,
    through `fault` when set, and records each request's path and headers."""

    def __init__(self, upstream: str) -> None:
        self.upstream = upstream  # read at each request
        self.fault: Optional[Fault] = None
        self.requests: List[Tuple[str, Dict[str, str]]] = []
        proxy = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 (http.server's name)
                proxy.requests.append((self.path, dict(self.headers.items())))
                forwarded = {k: v for k, v in self.headers.items() if k.lower() in ("range", "authorization")}
                try:
                    with urllib.request.urlopen(urllib.request.Request(proxy.upstream + self.path, headers=forwarded),
                                                timeout=30) as r:
                        status, headers, body = r.status, dict(r.headers.items()), r.read()
                except urllib.error.HTTPError as e:
                    status, headers, body = e.code, dict(e.headers.items()), e.read()
                    e.close()
                if proxy.fault is not None:
                    status, headers, body = proxy.fault(self.path, status, headers, body)
                self.send_response(status)
                for name, value in headers.items():
                    if name.lower() not in ("content-length", "transfer-encoding", "connection", "date", "server"):
                        self.send_header(name, value)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args: object) -> None:
                pass

        self._server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self._server.daemon_threads = True
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True)
        self._thread.start()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self._server.server_address[1]}"

    def close(self) -> None:
        self._server.shutdown()
        self._server.server_close()
        self._thread.join()


@pytest.fixture
def front(http_farm: FarmServer) -> Iterator[FaultyFrontEnd]:
    proxy = FaultyFrontEnd(http_farm.http_url)
    yield proxy
    proxy.close()


def listing(path: str) -> bool:
    return path.endswith("/manifest")


def digest_header(body: bytes) -> str:
    return "sha-256=:" + base64.b64encode(hashlib.sha256(body).digest()).decode() + ":"


def on_listing(change: Callable[[int, Dict[str, str], bytes], Answer]) -> Fault:
    def fault(path: str, status: int, headers: Dict[str, str], body: bytes) -> Answer:
        return change(status, headers, body) if listing(path) else (status, headers, body)

    return fault


def with_header(headers: Dict[str, str], name: str, value: Optional[str]) -> Dict[str, str]:
    out = {k: v for k, v in headers.items() if k.lower() != name.lower()}
    if value is not None:
        out[name] = value
    return out


def rewritten(change: Callable[[pb.Manifest], None]) -> Fault:
    """The listing parsed, changed and sent with its own, right, Repr-Digest."""

    def edit(status: int, headers: Dict[str, str], body: bytes) -> Answer:
        manifest = pb.Manifest.FromString(body)
        change(manifest)
        new = manifest.SerializeToString()
        return status, with_header(headers, "Repr-Digest", digest_header(new)), new

    return on_listing(edit)


def flip_a_byte_of(name: str) -> Fault:
    def fault(path: str, status: int, headers: Dict[str, str], body: bytes) -> Answer:
        if path.endswith(f"/files/{name}") and body:
            body = bytes([body[0] ^ 1]) + body[1:]
        return status, headers, body

    return fault


def _set_map_file(m: pb.Manifest) -> None:
    m.maps[0].file = "../escaped.png"


def _set_key(m: pb.Manifest) -> None:
    m.cache_key = "0" * 64


# Each spoiled answer and the words its error names.
SPOILED = {
    "wrong-repr-digest": (on_listing(lambda s, h, b: (s, with_header(h, "Repr-Digest", digest_header(b"x")), b)),
                          "cut or altered on the way"),
    "no-repr-digest": (on_listing(lambda s, h, b: (s, with_header(h, "Repr-Digest", None), b)),
                       "without its Repr-Digest header"),
    "truncated-listing": (on_listing(lambda s, h, b: (s, h, b[: len(b) // 2])), "cut or altered on the way"),
    "html-200": (on_listing(lambda s, h, b: (200, {"Content-Type": "text/html"}, b"<html>sign in</html>")),
                 "text/html, not a result's listing"),
    "listing-500": (on_listing(lambda s, h, b: (500, {"Content-Type": "application/json"},
                                                b'{"error":{"code":500,"message":"store on fire"}}')),
                    "HTTP 500: store on fire"),
    "another-result": (rewritten(_set_key), "not of the one asked for"),
    "escaping-file-name": (rewritten(_set_map_file), "is not a distinct plain file name"),
}


def files_in(folder: Path) -> Dict[str, bytes]:
    """Every entry of `folder` (hidden temporary files included)."""
    return {p.name: p.read_bytes() for p in folder.iterdir()} if folder.exists() else {}


def fallback_warnings(caplog: pytest.LogCaptureFixture) -> List[str]:
    return [r.getMessage() for r in caplog.records
            if r.name == LOGGER and r.levelno == logging.WARNING and "farm_http_fetch_fallback" in r.getMessage()]


def test_the_listing_is_the_farms_manifest_with_its_digest(http_farm: FarmServer, baked: Baked) -> None:
    url = f"{http_farm.http_url}/api/v1/results/{baked.key}/manifest"
    with urllib.request.urlopen(url, timeout=30) as r:
        body, headers = r.read(), r.headers
    assert headers["Content-Type"].startswith("application/x-protobuf")
    assert headers["Repr-Digest"] == digest_header(body)
    assert pb.Manifest.FromString(body).cache_key == baked.key


def test_fetch_over_the_front_end_alone_is_the_grpc_result_byte_for_byte(
        http_farm: FarmServer, baked: Baked, dead_address: str, tmp_path: Path,
        caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    # No gRPC server at the Client's address: the constructor does not
    # connect, and the fetch needs no connection.
    with impostor.Client(dead_address, farm_http=http_farm.http_url + "/", connect_timeout_seconds=5) as c:
        assert c.farm_http == http_farm.http_url
        fetched = c.fetch(baked.key, tmp_path / "out")
        assert files_in(tmp_path / "out") == baked.files
        assert [p.name for p in fetched.files] == [m["file"] for m in baked.manifest["maps"]] + ["manifest.json"]
        assert fetched.manifest == baked.manifest
        assert fetched.bytes_downloaded == sum(len(b) for b in baked.files.values()) and fetched.bytes_reused == 0
        # A second fetch keeps what is there; a damaged file is fetched again.
        (tmp_path / "out" / baked.last_map).write_bytes(b"damaged")
        again = c.fetch(baked.key, tmp_path / "out")
        assert again.bytes_downloaded == len(baked.files[baked.last_map])
        assert again.bytes_reused == fetched.bytes_downloaded - again.bytes_downloaded
        assert files_in(tmp_path / "out") == baked.files
        # gRPC is needed only by a gRPC call, and it is not there.
        with pytest.raises(impostor.ImpostorError) as no_grpc:
            c.get_job("any")
    assert no_grpc.value.code == grpc.StatusCode.UNAVAILABLE and no_grpc.value.rpc == "Connect"
    assert not fallback_warnings(caplog)


def test_files_fetched_over_the_front_end_are_plain_files_others_can_read(
        http_farm: FarmServer, baked: Baked, dead_address: str, tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        with impostor.Client(dead_address, farm_http=http_farm.http_url) as c:
            fetched = c.fetch(baked.key, tmp_path / "shared")
    finally:
        os.umask(old)
    for path in fetched.files:
        assert path.stat().st_mode & 0o777 == 0o644, path


def test_the_token_goes_to_the_front_end_as_a_bearer_header(
        front: FaultyFrontEnd, baked: Baked, dead_address: str, tmp_path: Path) -> None:
    with impostor.Client(dead_address, farm_http=front.url, token="s3cret-token") as c:
        c.fetch(baked.key, tmp_path / "out")
    assert len(front.requests) == len(baked.files) + 1, "the listing and each file once"
    assert listing(front.requests[0][0])
    assert all(headers.get("Authorization") == "Bearer s3cret-token" for _, headers in front.requests)


@pytest.mark.parametrize("case", list(SPOILED))
def test_a_spoiled_listing_falls_back_to_grpc_or_fails_naming_it(
        case: str, http_farm: FarmServer, front: FaultyFrontEnd, baked: Baked, dead_address: str,
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    front.fault, words = SPOILED[case]
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    with impostor.Client(http_farm.address, farm_http=front.url) as c:
        fetched = c.fetch(baked.key, tmp_path / "fell_back")
    assert files_in(tmp_path / "fell_back") == baked.files, "the exact result, over gRPC"
    assert fetched.manifest == baked.manifest
    (warning,) = fallback_warnings(caplog)
    assert words in warning and baked.key in warning
    # No gRPC either: the error names what the front end did.
    with impostor.Client(dead_address, farm_http=front.url) as c:
        with pytest.raises(impostor.ImpostorError) as caught:
            c.fetch(baked.key, tmp_path / "failed")
    assert caught.value.code == grpc.StatusCode.UNAVAILABLE, caught.value
    assert "refused" in caught.value.message and words in caught.value.message, caught.value
    assert "HTTP front end could not give the result" in caught.value.message
    assert files_in(tmp_path / "failed") == {}, "nothing of the result installed"


def test_a_wrong_byte_in_a_file_installs_nothing_and_falls_back(
        http_farm: FarmServer, front: FaultyFrontEnd, baked: Baked, dead_address: str, tmp_path: Path,
        caplog: pytest.LogCaptureFixture) -> None:
    front.fault = flip_a_byte_of(baked.last_map)
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    out = tmp_path / "out"
    out.mkdir()
    # Another result's manifest.json, and a map of it: the manifest goes first
    # (it would describe maps being replaced), the rest stays as it was.
    (out / "manifest.json").write_bytes(b'{"cache_key": "another result"}')
    (out / baked.last_map).write_bytes(b"another result's map")
    with impostor.Client(dead_address, farm_http=front.url) as c:
        with pytest.raises(impostor.ImpostorError) as caught:
            c.fetch(baked.key, out)
    assert caught.value.code == grpc.StatusCode.UNAVAILABLE
    assert "DATA_LOSS" in caught.value.message and baked.last_map in caught.value.message, caught.value
    assert "the bytes hash to" in caught.value.message, caught.value
    assert files_in(out) == {baked.last_map: b"another result's map"}, "no file renamed in, no temporary left"
    caplog.clear()
    with impostor.Client(http_farm.address, farm_http=front.url) as c:
        c.fetch(baked.key, out)
    assert files_in(out) == baked.files
    (warning,) = fallback_warnings(caplog)
    assert baked.last_map in warning


def test_a_front_end_that_refuses_connections_falls_back_to_grpc(
        http_farm: FarmServer, baked: Baked, dead_address: str, tmp_path: Path,
        caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    with impostor.Client(http_farm.address, farm_http=f"http://{dead_address}") as c:
        c.fetch(baked.key, tmp_path / "out")
    assert files_in(tmp_path / "out") == baked.files
    (warning,) = fallback_warnings(caplog)
    assert "refused" in warning, warning


def test_a_listing_404_goes_to_grpc_quietly(
        http_farm: FarmServer, front: FaultyFrontEnd, baked: Baked, tmp_path: Path,
        caplog: pytest.LogCaptureFixture) -> None:
    """A farm older than the listing's route answers 404: gRPC, no warning."""
    front.fault = on_listing(lambda s, h, b: (404, {"Content-Type": "application/json"},
                                              b'{"error":{"code":404,"message":"no such path"}}'))
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    with impostor.Client(http_farm.address, farm_http=front.url) as c:
        c.fetch(baked.key, tmp_path / "out")
        # Nothing baked under a key: NOT_FOUND, the server's, as without a front end.
        with pytest.raises(impostor.ImpostorError) as absent:
            c.fetch("0" * 64, tmp_path / "absent")
        with pytest.raises(impostor.ImpostorError) as malformed:
            c.fetch("not-a-key", tmp_path / "malformed")
    assert files_in(tmp_path / "out") == baked.files
    assert absent.value.code == grpc.StatusCode.NOT_FOUND and absent.value.rpc == "GetResult"
    assert malformed.value.code == grpc.StatusCode.INVALID_ARGUMENT and malformed.value.rpc == "GetResult"
    assert not fallback_warnings(caplog)
    assert any("farm_http_fetch_not_found" in r.getMessage() and r.levelno == logging.DEBUG for r in caplog.records)


def test_a_local_failure_is_not_retried_over_grpc(
        http_farm: FarmServer, baked: Baked, dead_address: str, tmp_path: Path,
        caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    (tmp_path / "a_file").write_bytes(b"")
    with impostor.Client(dead_address, farm_http=http_farm.http_url) as c:
        with pytest.raises(impostor.ImpostorError) as caught:
            c.fetch(baked.key, tmp_path / "a_file" / "out")
    assert caught.value.code == grpc.StatusCode.INTERNAL, caught.value
    assert "cannot create directory" in caught.value.message and caught.value.rpc is None
    assert not fallback_warnings(caplog)


def fill_the_disk_under(monkeypatch: pytest.MonkeyPatch, file_name: str) -> None:
    """Every write into the file staged for `file_name` fails as on a full
    disk (ENOSPC)."""
    from impostor import _result_install

    class FullDisk:
        def __init__(self, file: object) -> None:
            self._file = file

        def write(self, data: bytes) -> int:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        def __getattr__(self, name: str) -> object:
            return getattr(self._file, name)

    init = _result_install.StagedFile.__init__

    def staged_on_a_full_disk(self: "_result_install.StagedFile", path: Path) -> None:
        init(self, path)
        if path.name == file_name:
            self._file = FullDisk(self._file)  # type: ignore[assignment]

    monkeypatch.setattr(_result_install.StagedFile, "__init__", staged_on_a_full_disk)


def test_a_full_disk_while_a_file_streams_is_raised_as_it_is(
        http_farm: FarmServer, baked: Baked, dead_address: str, tmp_path: Path,
        caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    """A write that fails under the HTTP read is the disk's failure, not a
    broken connection: no retry, no gRPC, nothing installed."""
    fill_the_disk_under(monkeypatch, baked.last_map)
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    with impostor.Client(dead_address, farm_http=http_farm.http_url) as c:
        with pytest.raises(impostor.ImpostorError) as caught:
            c.fetch(baked.key, tmp_path / "out")
    assert caught.value.code == grpc.StatusCode.INTERNAL and caught.value.rpc is None, caught.value
    assert baked.last_map in caught.value.message and "free space" in caught.value.message, caught.value
    assert files_in(tmp_path / "out") == {}
    assert not fallback_warnings(caplog)


def test_impostor_farm_http_names_the_front_end(
        http_farm: FarmServer, baked: Baked, dead_address: str, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("IMPOSTOR_FARM_HTTP", http_farm.http_url)
    with impostor.Client(dead_address) as c:
        assert c.farm_http == http_farm.http_url
        c.fetch(baked.key, tmp_path / "from_env")
    assert files_in(tmp_path / "from_env") == baked.files
    # farm_http="none" turns it off: gRPC, connected at once as before.
    with pytest.raises(impostor.ImpostorError) as connect:
        impostor.Client(dead_address, farm_http="none", connect_timeout_seconds=5)
    assert connect.value.code == grpc.StatusCode.UNAVAILABLE and connect.value.rpc == "Connect"
    with impostor.Client(http_farm.address, farm_http="none") as c:
        assert c.farm_http == ""
    # So does the variable's "none".
    monkeypatch.setenv("IMPOSTOR_FARM_HTTP", "none")
    with pytest.raises(impostor.ImpostorError) as connect:
        impostor.Client(dead_address, connect_timeout_seconds=5)
    assert connect.value.rpc == "Connect"
    # The argument wins over the variable.
    monkeypatch.setenv("IMPOSTOR_FARM_HTTP", "ftp://not-a-front-end")
    with impostor.Client(dead_address, farm_http=http_farm.http_url) as c:
        assert c.farm_http == http_farm.http_url
    with pytest.raises(impostor.ImpostorError) as bad_env:
        impostor.Client(dead_address)
    assert bad_env.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "$IMPOSTOR_FARM_HTTP" in bad_env.value.message and "ftp://" in bad_env.value.message


@pytest.mark.parametrize(
    "url, words",
    [
        ("farm.example.com:8080", "is not an http:// or https:// URL"),
        ("ftp://farm.example.com", "is not an http:// or https:// URL"),
        ("http://", "names no host"),
        ("http://:8080", "names no host"),
        ("http://user:secret@farm.example.com", "carries credentials"),
        ("http://farm.example.com/?key=1", "has a query or a fragment"),
        ("http://farm example.com", "a space, a control or a non-ASCII character"),
        ("http://farm.example.com/" + "a" * 2100, "over the limit of 2048"),
    ],
    ids=["no-scheme", "ftp", "no-host", "port-only", "credentials", "query", "space", "too-long"],
)
def test_a_malformed_farm_http_is_invalid_argument_naming_it(url: str, words: str, dead_address: str) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        impostor.Client(dead_address, farm_http=url)
    assert caught.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert caught.value.message.startswith("farm_http: ") and words in caught.value.message, caught.value


def test_a_plaintext_front_end_is_refused_beside_tls_grpc(dead_address: str, tmp_path: Path) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        impostor.Client(dead_address, tls_ca=tmp_path / "ca.pem", farm_http="http://farm.example.com")
    assert caught.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "farm_http" in caught.value.message and "https://" in caught.value.message, caught.value


def test_bad_client_options_are_refused_before_any_connection(dead_address: str, tmp_path: Path) -> None:
    """With a front end the constructor connects to nothing, but checks every
    option as before."""
    with pytest.raises(impostor.ImpostorError) as caught:
        impostor.Client(dead_address, farm_http="http://127.0.0.1:1", max_attempts=0)
    assert caught.value.code == grpc.StatusCode.INVALID_ARGUMENT and "max_attempts" in caught.value.message
    with pytest.raises(impostor.ImpostorError) as unreadable:
        impostor.Client(dead_address, farm_http="https://127.0.0.1:1", tls_ca=tmp_path / "missing.pem")
    assert unreadable.value.code == grpc.StatusCode.INVALID_ARGUMENT and "tls_ca" in unreadable.value.message


# -- the front end the farm advertises (--http-advertise) ----------------------


@pytest.fixture
def advertised(advertised_proxy: FaultyFrontEnd, monkeypatch: pytest.MonkeyPatch) -> FaultyFrontEnd:
    """The advertised proxy, without fault or requests; files over LARGE
    bytes are the large ones."""
    advertised_proxy.fault = None
    advertised_proxy.requests.clear()
    monkeypatch.setattr(_blobs, "BATCH_BLOB_MAX_BYTES", LARGE)
    return advertised_proxy


def large_files(baked: Baked) -> List[str]:
    names = [name for name, body in baked.files.items() if len(body) > LARGE]
    assert names, "the quick bake has files over LARGE bytes"
    return names


def file_requests(front: FaultyFrontEnd) -> List[str]:
    """The names of the files asked of `front`, in order (nothing else is
    expected: any other request shows as itself)."""
    out = []
    for path, _ in front.requests:
        prefix, _, name = path.rpartition("/files/")
        out.append(urllib.parse.unquote(name) if prefix else path)
    return out


def warnings_of(caplog: pytest.LogCaptureFixture, event: str) -> List[str]:
    return [r.getMessage() for r in caplog.records
            if r.name == LOGGER and r.levelno == logging.WARNING and f"event={event}" in r.getMessage()]


class GrpcWatch:
    """The Client's transport, counting its ReadBlob streams; `advertise`
    (when set) replaces the front end GetResult's answers name."""

    def __init__(self, inner: object, advertise: Optional[str] = None) -> None:
        self._inner = inner
        self._advertise = advertise
        self.streams = 0

    def __getattr__(self, name: str) -> object:
        return getattr(self._inner, name)

    def read_blob(self, request: object, remaining_bytes: int) -> object:
        self.streams += 1
        return self._inner.read_blob(request, remaining_bytes)  # type: ignore[attr-defined]

    def unary_with_initial_metadata(self, rpc: str, method: object, request: object,
                                    timeout: Optional[float] = None) -> object:
        response, metadata = self._inner.unary_with_initial_metadata(  # type: ignore[attr-defined]
            rpc, method, request, timeout)
        if self._advertise is not None:
            key = _farm_http.FARM_HTTP_METADATA_KEY
            metadata = [(k, v) for k, v in metadata if k != key] + [(key, self._advertise)]
        return response, metadata


def watched(client: impostor.Client, advertise: Optional[str] = None) -> GrpcWatch:
    watch = GrpcWatch(client._transport, advertise)
    client._transport = watch  # type: ignore[assignment]
    return watch


def test_the_large_files_come_from_the_front_end_the_farm_advertises(
        http_farm: FarmServer, advertised: FaultyFrontEnd, baked: Baked, tmp_path: Path,
        caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    with impostor.Client(http_farm.address, token="s3cret-token") as c:
        assert c.farm_http == "", "none given"
        grpc_side = watched(c)
        fetched = c.fetch(baked.key, tmp_path / "out")
    assert files_in(tmp_path / "out") == baked.files, "byte for byte"
    assert fetched.manifest == baked.manifest
    assert sorted(file_requests(advertised)) == sorted(large_files(baked)), "each large file once, nothing else"
    assert all(h.get("Authorization") == "Bearer s3cret-token" for _, h in advertised.requests)
    assert grpc_side.streams == 0, "no ReadBlob: the small files came in batches"
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_a_spoiled_large_file_from_the_advertised_front_end_comes_over_read_blob(
        http_farm: FarmServer, advertised: FaultyFrontEnd, baked: Baked, tmp_path: Path,
        caplog: pytest.LogCaptureFixture) -> None:
    spoiled = large_files(baked)[0]
    advertised.fault = flip_a_byte_of(spoiled)
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    with impostor.Client(http_farm.address) as c:
        grpc_side = watched(c)
        c.fetch(baked.key, tmp_path / "out")
    assert files_in(tmp_path / "out") == baked.files, "the exact result"
    assert sorted(file_requests(advertised)) == sorted(large_files(baked))
    assert grpc_side.streams == 1, "the spoiled file alone over ReadBlob"
    (warning,) = warnings_of(caplog, "farm_http_fallback")
    assert spoiled in warning and baked.key in warning and "the bytes hash to" in warning, warning
    assert not warnings_of(caplog, "farm_http_given_up")


@pytest.mark.parametrize("where", ["argument", "env"])
def test_none_ignores_the_advertised_front_end(
        where: str, http_farm: FarmServer, advertised: FaultyFrontEnd, baked: Baked, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    if where == "env":
        monkeypatch.setenv("IMPOSTOR_FARM_HTTP", "none")
    with impostor.Client(http_farm.address, **({"farm_http": "none"} if where == "argument" else {})) as c:
        grpc_side = watched(c)
        c.fetch(baked.key, tmp_path / "out")
    assert files_in(tmp_path / "out") == baked.files
    assert advertised.requests == [], "the front end was not asked"
    assert grpc_side.streams == len(large_files(baked)), "the large files over ReadBlob"


def test_a_configured_front_end_takes_no_advertised_one(
        http_farm: FarmServer, advertised: FaultyFrontEnd, front: FaultyFrontEnd, baked: Baked,
        tmp_path: Path) -> None:
    """Given one, the whole result comes from it; when it cannot give it, the
    whole result over gRPC, as before: the advertised one is never asked."""
    with impostor.Client(http_farm.address, farm_http=front.url) as c:
        c.fetch(baked.key, tmp_path / "given")
        front.fault = on_listing(lambda s, h, b: (500, h, b"no"))
        c.fetch(baked.key, tmp_path / "fell_back")
    assert files_in(tmp_path / "given") == baked.files and files_in(tmp_path / "fell_back") == baked.files
    assert advertised.requests == []


def test_a_refused_advertisement_warns_once_and_results_come_over_grpc(
        http_farm: FarmServer, advertised: FaultyFrontEnd, baked: Baked, tmp_path: Path,
        caplog: pytest.LogCaptureFixture) -> None:
    """An advertisement a client must not use (the farm checks its own flag
    as the client does, so a GetResult answer is rewritten here): one
    warning for the Client, every result over gRPC."""
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    with impostor.Client(http_farm.address) as c:
        grpc_side = watched(c, advertise="http://user:secret@127.0.0.1:1")
        c.fetch(baked.key, tmp_path / "one")
        c.fetch(baked.key, tmp_path / "two")
    assert files_in(tmp_path / "one") == baked.files and files_in(tmp_path / "two") == baked.files
    assert grpc_side.streams == 2 * len(large_files(baked))
    assert advertised.requests == []
    (warning,) = warnings_of(caplog, "farm_http_advertisement_refused")
    assert "carries credentials" in warning and "user:secret@127.0.0.1:1" in warning, warning


def test_an_advertisement_is_checked_as_a_configured_front_end(caplog: pytest.LogCaptureFixture) -> None:
    """With TLS gRPC only https://; one warning per value refused; a refused
    value leaves the front end in use as it was."""
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    choice = _farm_http.AdvertisedFrontEnd(tls=True, token=None, ca_file=None, timeout_seconds=5)
    choice.learn("http://farm.example:8080")
    choice.learn("http://farm.example:8080")
    assert choice.current() is None
    (warning,) = warnings_of(caplog, "farm_http_advertisement_refused")
    assert "plaintext" in warning and "https://" in warning, warning
    choice.learn("https://farm.example/impostor/")
    current = choice.current()
    assert current is not None and current.base == "https://farm.example/impostor"
    choice.learn("ftp://farm.example")
    assert choice.current() is current
    assert len(warnings_of(caplog, "farm_http_advertisement_refused")) == 2
    plain = _farm_http.AdvertisedFrontEnd(tls=False, token=None, ca_file=None, timeout_seconds=5)
    plain.learn("http://farm.example:8080")
    assert plain.current() is not None and plain.current().base == "http://farm.example:8080"  # type: ignore


def test_the_advertised_front_end_is_given_up_after_3_files_in_a_row(
        http_farm: FarmServer, advertised: FaultyFrontEnd, baked: Baked, tmp_path: Path,
        caplog: pytest.LogCaptureFixture) -> None:
    """Files asked of it fail, fail, pass, fail, fail, fail: the pass starts
    the count over, the sixth request is the third failure in a row, and
    nothing more is asked; every result is exact, over ReadBlob where the
    front end did not give a file."""
    failing = {0, 1, 3, 4, 5}
    asked = [0]
    lock = threading.Lock()

    def fault(path: str, status: int, headers: Dict[str, str], body: bytes) -> Answer:
        with lock:
            n = asked[0]
            asked[0] += 1
        if n in failing:
            return 503, {"Content-Type": "application/json"}, b'{"error":{"code":503,"message":"busy (test)"}}'
        return status, headers, body

    advertised.fault = fault
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    large = len(large_files(baked))
    with impostor.Client(http_farm.address) as c:
        grpc_side = watched(c)
        fetches = 0
        while not warnings_of(caplog, "farm_http_given_up"):
            assert fetches < 6, "given up by the sixth file"
            c.fetch(baked.key, tmp_path / f"out{fetches}")
            assert files_in(tmp_path / f"out{fetches}") == baked.files
            fetches += 1
        assert len(advertised.requests) == 6
        c.fetch(baked.key, tmp_path / "after")
    assert files_in(tmp_path / "after") == baked.files
    assert len(advertised.requests) == 6, "nothing asked once given up"
    assert grpc_side.streams == (fetches + 1) * large - 1, "all but the one file the front end gave"
    assert len(warnings_of(caplog, "farm_http_fallback")) == 5
    (given_up,) = warnings_of(caplog, "farm_http_given_up")
    assert advertised.url in given_up and "failures_in_a_row=3" in given_up and "HTTP 503" in given_up


def test_a_full_disk_under_the_advertised_front_end_is_raised_as_it_is(
        http_farm: FarmServer, advertised: FaultyFrontEnd, baked: Baked, tmp_path: Path,
        caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    victim = large_files(baked)[0]
    fill_the_disk_under(monkeypatch, victim)
    caplog.set_level(logging.DEBUG, logger=LOGGER)
    with impostor.Client(http_farm.address) as c:
        grpc_side = watched(c)
        with pytest.raises(impostor.ImpostorError) as caught:
            c.fetch(baked.key, tmp_path / "out")
    assert caught.value.code == grpc.StatusCode.INTERNAL and caught.value.rpc is None, caught.value
    assert victim in caught.value.message and "free space" in caught.value.message, caught.value
    assert victim in file_requests(advertised) and grpc_side.streams == 0, "not tried again over ReadBlob"
    assert files_in(tmp_path / "out") == {}, "nothing renamed in, no temporary left"
    assert not warnings_of(caplog, "farm_http_fallback")
