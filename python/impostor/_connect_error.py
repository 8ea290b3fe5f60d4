"""Why a channel could not reach an impostor server, as a sentence that names
the fix, from gRPC's message for the failed call: the Python twin of
common/connect_error.cc (keep the two in step; the C++ side also tells an
expired server certificate from a foreign one with a handshake of its own,
which this one does not)."""
from __future__ import annotations

from typing import Tuple


def explain_connect_error(message: str, uses_tls: bool) -> Tuple[str, bool]:
    """(sentence, silent): `silent` when a connection was accepted but no gRPC
    server answered (a stopped or overloaded server), worth waiting out."""

    def has(text: str) -> bool:
        return text in message

    if uses_tls:
        if has("certificate verify failed"):
            return (
                "TLS handshake failed: the server's certificate does not verify against the CA given "
                f"(tls_ca): another CA, or expired ({message})",
                False,
            )
        if has("No match found for server name") or has("Peer name"):
            return (
                "TLS handshake failed: the server's certificate does not carry the name dialled "
                f"({message})",
                False,
            )
        if has("wrong version number") or has("packet length too long") or has("http request"):
            return (f"TLS handshake failed: the server does not speak TLS; connect without tls_ca ({message})", False)
        if has("Handshake") or has("handshake") or has("SSL") or has("certificate") or has("Socket closed"):
            return (
                "TLS handshake failed: the server ended it (a server run with --tls-client-ca needs a client "
                "certificate it trusts: tls_cert/tls_key; or the server's own certificate files are unusable: "
                f"its log says event=tls_files_refused) ({message})",
                False,
            )
    if has("DNS resolution failed") or has("Domain name not found") or has("name resolution"):
        return (f"the host name does not resolve ({message})", False)
    if has("Connection refused"):
        return ("connection refused; is impostor-server running there?", False)
    if has("Failed parsing HTTP/2") or has("http1") or has("HTTP/1"):
        return (
            "something answers on that port, but it is not a gRPC server; is it impostor-server's port? "
            f"({message})",
            False,
        )
    if has("before receiving SETTINGS") or has("Deadline Exceeded") or has("timed out"):
        return (
            "a connection was accepted but no gRPC server answered on it (a stopped or overloaded server, or "
            f"another program on that port) ({message})",
            True,
        )
    if has("Socket closed") or has("Connection reset") or has("connection closed") or has("EOF"):
        return (f"the server closed the connection; if it serves TLS, connect with its CA (tls_ca) ({message})", False)
    return (f"cannot connect ({message or 'no reason given'})", False)
