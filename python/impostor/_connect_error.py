"""Why a channel could not reach an impostor server, as a sentence that names
the fix, from gRPC's message for the failed call: the Python twin of
common/net/connect_error.cc (keep the two in step)."""
from __future__ import annotations

from typing import Callable, Optional, Tuple


def explain_connect_error(
    message: str, uses_tls: bool, diagnose_certificate: Optional[Callable[[], str]] = None
) -> Tuple[str, bool]:
    """(sentence, silent): `silent` when a connection was accepted but no gRPC
    server answered (a stopped or overloaded server), worth waiting out.
    `diagnose_certificate` (_tls_peer_check) is called only when gRPC's
    message is of a certificate the client refused, and says why, or "" when
    it cannot tell."""

    def has(text: str) -> bool:
        return text in message

    if uses_tls:
        # gRPC says "certificate verify failed" for an expired certificate,
        # one not valid yet and one from another CA alike, and checks the
        # name itself ("Peer name ... is not in peer certificate"); a
        # handshake of our own tells which, and names the date, issuer or name.
        refused = has("certificate verify failed") or has("No match found for server name") or has("Peer name")
        why = diagnose_certificate() if refused and diagnose_certificate is not None else ""
        if why:
            return (f"TLS handshake failed: {why} ({message})", False)
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
