"""TLS and mutual TLS from the client's side (tls_ca, tls_cert, tls_key),
against a stand-in BakeService on a TLS listener: the farm's own TLS
listener is another change. Certificates: a throwaway CA made with the
openssl CLI, the server's for "localhost"."""
from __future__ import annotations

import subprocess
from concurrent import futures
from pathlib import Path
from typing import Iterator, Tuple

import grpc
import pytest

import impostor
from impostor.v1 import bake_service_pb2_grpc, types_pb2


def openssl(*args: str, cwd: Path) -> None:
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True)


@pytest.fixture(scope="module")
def pki(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("pki")
    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj", "/CN=test CA",
            "-keyout", "ca.key", "-out", "ca.pem", cwd=d)
    for name in ("server", "client"):
        openssl("req", "-newkey", "rsa:2048", "-nodes", "-subj", f"/CN={name}", "-keyout", f"{name}.key",
                "-out", f"{name}.csr", cwd=d)
        (d / f"{name}.ext").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
        openssl("x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial",
                "-days", "2", "-extfile", f"{name}.ext", "-out", f"{name}.pem", cwd=d)
    # A second CA that signed nothing here.
    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj", "/CN=other CA",
            "-keyout", "other.key", "-out", "other.pem", cwd=d)
    return d


class Answering(bake_service_pb2_grpc.BakeServiceServicer):
    def GetJob(self, request, context):  # noqa: N802 (gRPC's name)
        return types_pb2.Job(job_id=request.job_id, state=types_pb2.JOB_STATE_RUNNING)


def tls_server(pki: Path, require_client_cert: bool) -> Tuple[grpc.Server, int]:
    server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
    bake_service_pb2_grpc.add_BakeServiceServicer_to_server(Answering(), server)
    credentials = grpc.ssl_server_credentials(
        [((pki / "server.key").read_bytes(), (pki / "server.pem").read_bytes())],
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
