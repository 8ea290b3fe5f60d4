"""The one exception type of the package."""
from __future__ import annotations

from typing import Optional

import grpc


class ImpostorError(Exception):
    """A failed call, a failed bake or a local problem with the input.

    Attributes:
        code: the gRPC status code. For an RPC that failed it is the server's
            (or the transport's) code; for a bake that ran and failed it is the
            job's error code (e.g. ``FAILED_PRECONDITION`` for a quality gate);
            local problems use the code the C++ SDK uses (``NOT_FOUND`` for a
            missing model file, ``INVALID_ARGUMENT`` for a malformed glTF,
            ``PERMISSION_DENIED`` for a symbolic link leading out of the
            model's folder, ``DATA_LOSS`` for a download whose bytes do not
            match its digest).
        message: one line saying what went wrong, naming the RPC and server
            for RPC errors.
        server_message: the server's own message, unchanged (empty for local
            problems).
        rpc: the RPC that failed (e.g. ``"SubmitBake"``), or None for local
            problems and failed bakes.
        server: the server address for RPC errors, else None.
        reason: why the server refused, as a stable word to act on instead of
            parsing server_message (the trailing metadata
            ``impostor-error-reason``, e.g. ``"TOKEN_PENDING_JOBS"``; README.md,
            Quotas, lists them); "" when the server gave none.
        job_id, cache_key: set when a bake failed or was cancelled (a result
            that failed a quality gate can still be fetched by cache_key).
    """

    def __init__(
        self,
        code: grpc.StatusCode,
        message: str,
        *,
        server_message: str = "",
        rpc: Optional[str] = None,
        server: Optional[str] = None,
        job_id: Optional[str] = None,
        cache_key: Optional[str] = None,
        reason: str = "",
    ) -> None:
        super().__init__(f"{code.name}: {message}")
        self.code = code
        self.message = message
        self.server_message = server_message
        self.rpc = rpc
        self.server = server
        self.job_id = job_id
        self.cache_key = cache_key
        self.reason = reason
        # Set by the transport on an UNAVAILABLE when calls moved on to
        # another address that has not failed since the last answer: the
        # call may be tried there at once.
        self.failover_now = False

    @property
    def is_rpc_error(self) -> bool:
        """True when the error came from an RPC (as GetRpcErrorInfo in the C++ SDK)."""
        return self.rpc is not None


_CODES_BY_VALUE = {code.value[0]: code for code in grpc.StatusCode}


def status_code_from_int(value: int) -> grpc.StatusCode:
    """The grpc.StatusCode of a canonical code number (UNKNOWN if out of range)."""
    return _CODES_BY_VALUE.get(value, grpc.StatusCode.UNKNOWN)


# The trailing metadata that carries the server's error reason
# (common/error_reason.h).
_REASON_KEY = "impostor-error-reason"


def _reason_of(error: grpc.RpcError) -> str:
    trailers = error.trailing_metadata() if isinstance(error, grpc.Call) else None
    for key, value in trailers or ():
        if key == _REASON_KEY:
            return value.decode("ascii", "replace") if isinstance(value, bytes) else str(value)
    return ""


def rpc_error(error: grpc.RpcError, rpc: str, server: str) -> ImpostorError:
    """Turns a grpc.RpcError into an ImpostorError naming the RPC and server."""
    code = error.code() if isinstance(error, grpc.Call) else grpc.StatusCode.UNKNOWN
    details = (error.details() if isinstance(error, grpc.Call) else None) or str(error)
    return ImpostorError(
        code,
        f"{rpc} to {server}: {details}",
        server_message=details,
        rpc=rpc,
        server=server,
        reason=_reason_of(error),
    )
