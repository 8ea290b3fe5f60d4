"""TLS and mutual TLS from the client's side (tls_ca, tls_cert, tls_key),
against a stand-in BakeService on a TLS listener (the real farm with TLS
and tokens: test_auth_tls.py). Certificates: conftest's throwaway PKI."""
from __future__ import annotations

from concurrent import futures
from pathlib import Path
from typing import Iterator, Tuple

import grpc
import pytest

import impostor
from impostor.v1 import bake_service_pb2_grpc, types_pb2


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
