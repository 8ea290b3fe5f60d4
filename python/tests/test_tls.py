"""TLS and mutual TLS from the client's side (tls_ca, tls_cert, tls_key),
against a stand-in BakeService on a TLS listener (the real farm with TLS
and tokens: test_auth_tls.py). Certificates: conftest's throwaway PKI."""
from __future__ import annotations

import socket
import ssl
from concurrent import futures
from pathlib import Path
from typing import Iterator, Optional, Tuple

import grpc
import pytest

import impostor
from impostor import _tls_peer_check
from impostor._connect_error import explain_connect_error
from impostor.v1 import bake_service_pb2_grpc, types_pb2

from conftest import openssl


class Answering(bake_service_pb2_grpc.BakeServiceServicer):
    def GetJob(self, request, context):  # noqa: N802 (gRPC's name)
        return types_pb2.Job(job_id=request.job_id, state=types_pb2.JOB_STATE_RUNNING)


def tls_server(pki: Path, require_client_cert: bool, cert: Optional[Path] = None) -> Tuple[grpc.Server, int]:
    """Serves `cert` (default: pki/server.pem) with pki/server.key; gRPC
    serves a certificate whatever its dates or issuer."""
    server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
    bake_service_pb2_grpc.add_BakeServiceServicer_to_server(Answering(), server)
    credentials = grpc.ssl_server_credentials(
        [((pki / "server.key").read_bytes(), (cert or pki / "server.pem").read_bytes())],
        root_certificates=(pki / "ca.pem").read_bytes() if require_client_cert else None,
        require_client_auth=require_client_cert)
    port = server.add_secure_port("127.0.0.1:0", credentials)
    server.start()
    return server, port


@pytest.fixture
def tls(pki: Path) -> Iterator[int]:
    server, port = tls_server(pki, require_client_cert=False)
    yield port
    server.stop(None)


@pytest.fixture
def mtls(pki: Path) -> Iterator[int]:
    server, port = tls_server(pki, require_client_cert=True)
    yield port
    server.stop(None)


def test_tls_with_the_servers_ca(pki: Path, tls: int) -> None:
    with impostor.Client(f"localhost:{tls}", tls_ca=pki / "ca.pem") as c:
        assert c.get_job("j").state == "running"


@pytest.mark.parametrize("ca", [None, "other.pem"], ids=["plaintext", "wrong-ca"])
def test_tls_server_refuses_other_clients(pki: Path, tls: int, ca) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        impostor.Client(f"localhost:{tls}", tls_ca=pki / ca if ca else None, connect_timeout_seconds=5)
    assert caught.value.code == grpc.StatusCode.UNAVAILABLE and caught.value.rpc == "Connect"


def test_mutual_tls_with_a_client_certificate(pki: Path, mtls: int) -> None:
    with impostor.Client(f"localhost:{mtls}", tls_ca=pki / "ca.pem", tls_cert=pki / "client.pem",
                         tls_key=pki / "client.key") as c:
        assert c.get_job("j").state == "running"


def test_mutual_tls_without_a_client_certificate_fails(pki: Path, mtls: int) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        with impostor.Client(f"localhost:{mtls}", tls_ca=pki / "ca.pem", connect_timeout_seconds=5,
                             max_attempts=1) as c:
            c.get_job("j")
    assert caught.value.code == grpc.StatusCode.UNAVAILABLE


@pytest.fixture(scope="module")
def refused_certs(pki: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Certificates for pki/server.key that a client trusting pki/ca.pem
    refuses: expired.pem, future.pem (not valid yet), elsewhere.pem (for
    another name only; else good) and foreign.pem (signed by pki/other.pem,
    "CN=other CA"). `openssl ca` since OpenSSL 3.0's `x509` cannot set a
    start date; fixed dates keep the sentences exact."""
    d = tmp_path_factory.mktemp("refused")
    (d / "ca.cnf").write_text(
        "[ca]\ndefault_ca = test_ca\n[test_ca]\ndatabase = index.txt\nnew_certs_dir = .\nserial = serial\n"
        "default_md = sha256\npolicy = any\nunique_subject = no\n[any]\ncommonName = supplied\n")
    (d / "index.txt").write_text("")
    (d / "serial").write_text("01\n")
    (d / "localhost.ext").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
    (d / "elsewhere.ext").write_text("subjectAltName=DNS:elsewhere.example\n")
    for name, ca, ext, dates in [
        ("expired", "ca", "localhost", ["-startdate", "20200101000000Z", "-enddate", "20200102000000Z"]),
        ("future", "ca", "localhost", ["-startdate", "20990101000000Z", "-enddate", "20991231000000Z"]),
        ("elsewhere", "ca", "elsewhere", ["-days", "2"]),
        ("foreign", "other", "localhost", ["-days", "2"]),
    ]:
        openssl("ca", "-batch", "-config", "ca.cnf", "-cert", str(pki / f"{ca}.pem"), "-keyfile",
                str(pki / f"{ca}.key"), "-in", str(pki / "server.csr"), "-extfile", f"{ext}.ext", *dates,
                "-out", f"{name}.pem", cwd=d)
    return d


# gRPC says "certificate verify failed" (or, for the name, "Peer name ... is
# not in peer certificate") for each; the client says which and what to fix,
# in common/net/tls_peer_check.cc's words.
REFUSED = [
    ("expired", "localhost",
     "the server's certificate expired on 2020-01-02 00:00:00 UTC; it must be renewed on the server "
     "(--tls-cert, --tls-key)"),
    ("future", "localhost",
     "the server's certificate is not valid until 2099-01-01 00:00:00 UTC; is this machine's clock "
     "(or the server's) right?"),
    ("foreign", "localhost",
     "the server's certificate (issuer CN=other CA) is not signed by the CA given (tls_ca)"),
    ("elsewhere", "localhost",
     "the server's certificate does not carry the name localhost; connect to it by a name it carries"),
    ("elsewhere", "127.0.0.1",
     "the server's certificate does not carry the name 127.0.0.1; connect to it by a name it carries"),
]


@pytest.mark.parametrize("cert,host,expected", REFUSED, ids=[f"{c}-{h}" for c, h, _ in REFUSED])
@pytest.mark.parametrize("mutual", [False, True], ids=["tls", "mtls"])
def test_a_refused_server_certificate_is_explained(pki: Path, refused_certs: Path, cert: str, host: str,
                                                   expected: str, mutual: bool) -> None:
    server, port = tls_server(pki, require_client_cert=mutual, cert=refused_certs / f"{cert}.pem")
    try:
        client_cert = {"tls_cert": pki / "client.pem", "tls_key": pki / "client.key"} if mutual else {}
        with pytest.raises(impostor.ImpostorError) as caught:
            impostor.Client(f"{host}:{port}", tls_ca=pki / "ca.pem", connect_timeout_seconds=5, **client_cert)
    finally:
        server.stop(None)
    error = caught.value
    assert error.code == grpc.StatusCode.UNAVAILABLE and error.rpc == "Connect"
    # gRPC's own message follows in parentheses.
    assert error.server_message.startswith(f"TLS handshake failed: {expected} ("), error.server_message
    assert error.message == f"Connect to {host}:{port}: {error.server_message}"


def test_the_certificate_is_read_alike_with_and_without_the_cryptography_package(refused_certs: Path) -> None:
    pytest.importorskip("cryptography")
    pem = (refused_certs / "expired.pem").read_text()  # `openssl ca` writes a text dump first
    der = ssl.PEM_cert_to_DER_cert(pem[pem.index("-----BEGIN CERTIFICATE-----"):])
    expected = ("2020-01-01 00:00:00 UTC", "2020-01-02 00:00:00 UTC", "CN=test CA")
    assert tuple(_tls_peer_check._peer_facts_cryptography(der)) == expected
    assert tuple(_tls_peer_check._peer_facts_stdlib(der)) == expected


def test_when_the_check_cannot_tell_grpcs_reason_stands(pki: Path) -> None:
    # Nobody listens on a port just bound and closed; other targets are not
    # HOST:PORT. Neither raises.
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    ca = (pki / "ca.pem").read_bytes()
    for target in [f"127.0.0.1:{port}", "dns:///localhost:1", "unix:/nowhere", "::1"]:
        assert _tls_peer_check.diagnose_server_certificate(target, ca, None, None, 1.0) == "", target
    message = "Ssl handshake failed: SSL_ERROR_SSL: error:0A000086:SSL routines::certificate verify failed"
    why, _ = explain_connect_error(message, True, lambda: "")
    assert why == ("TLS handshake failed: the server's certificate does not verify against the CA given "
                   f"(tls_ca): another CA, or expired ({message})")


def test_a_certificate_that_verifies_is_not_explained(pki: Path, tls: int) -> None:
    ca = (pki / "ca.pem").read_bytes()
    assert _tls_peer_check.diagnose_server_certificate(f"localhost:{tls}", ca, None, None, 2.0) == ""
