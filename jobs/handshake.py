"""Ask a scheduler address who it is, with a deadline, before a Client is made.

``distributed.Client(address, timeout=...)`` bounds reaching the port, not Dask's
handshake after it (issue 26): a port that accepts and never answers (a stuck process,
a dashboard port given as the scheduler) hung ``farm sweep submit`` for minutes, and a
port that answers with other bytes (an HTTP server) was read as a Dask frame length
("Unable to allocate 3.07 EiB"). :func:`check_scheduler` opens one connection, sends
Dask's ``identity`` request, and wants a reply of type ``Scheduler`` within ``timeout``
seconds overall; anything else is one :class:`~jobs.errors.ClusterError` line naming
the address and what was expected.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import socket
import time
from typing import Any

from jobs.errors import ClusterError

PROBE_SECONDS = 2.0  # the plain probe of what answers instead, after the handshake failed
HINT = ("give the address of a running Dask scheduler (`dask scheduler` prints it, port 8786 "
        "by default; not its dashboard, 8787)")


async def _identity(address: str, timeout: float, connection_args: dict[str, Any]) -> Any:
    from distributed.comm import connect

    deadline = time.monotonic() + timeout

    def left() -> float:
        return max(deadline - time.monotonic(), 0.01)

    comm = await asyncio.wait_for(connect(address, timeout=left(), **connection_args), left())
    try:
        await asyncio.wait_for(comm.write({"op": "identity", "reply": True}), left())
        return await asyncio.wait_for(comm.read(), left())
    finally:
        comm.abort()


def _check_listening(address: str, timeout: float) -> None:
    """Refuse a TCP address nothing listens on at once, before the handshake's deadline
    (distributed retries a refused connection until its timeout)."""
    scheme, _, rest = address.partition("://")
    if scheme not in ("tcp", "tls"):
        return
    from distributed.comm.addressing import parse_host_port

    try:
        host, port = parse_host_port(rest)
    except ValueError as e:
        raise ClusterError(f"{address!r} is not a scheduler address ({e}): {HINT}") from e
    socket.create_connection((host, port), timeout=timeout).close()  # OSError: unreachable


def _who_answers(first: str, error: BaseException) -> str:
    """What answers at ``address`` instead of Dask, in words: its first line when a plain
    request gets one (an HTTP server or proxy, an SSH server's banner), else the error
    Dask's reader raised. Dask read an HTTP reply's first bytes as a frame length, "Unable
    to allocate 3.07 EiB" (issue 50: on a network whose proxy answers for every address,
    an unroutable host looked like that)."""
    if first.startswith("HTTP/"):
        return (f"an HTTP server answers there, {first!r}: a web service or a proxy; "
                "behind a proxy an unreachable host can look like this")
    if first.startswith("SSH-"):
        return f"an SSH server answers there, {first!r}"
    if first:
        return f"it answered {first!r}"
    return f"{type(error).__name__}{': ' + str(error)[:120] if str(error) else ''}"


def _first_line(address: str, timeout: float = PROBE_SECONDS) -> str:
    """The first line (at most 60 characters) a plain TCP peer at ``address`` sends after
    an HTTP request; empty when it sends none or is not plain TCP."""
    scheme, _, rest = address.partition("://")
    if scheme != "tcp":
        return ""
    from distributed.comm.addressing import parse_host_port

    try:
        host, port = parse_host_port(rest)
        with socket.create_connection((host, port), timeout=timeout) as sock:
            sock.settimeout(timeout)
            sock.sendall(b"GET / HTTP/1.0\r\nHost: " + host.encode() + b"\r\n\r\n")
            data = sock.recv(256)
    except (OSError, ValueError):
        return ""
    line = data.split(b"\n", 1)[0].decode("ascii", "replace").strip()
    return "".join(c if c.isprintable() else "?" for c in line)[:60]


def check_scheduler(address: str, timeout: float, connection_args: dict[str, Any] | None = None
                    ) -> dict[str, Any]:
    """The scheduler's identity; raises :class:`ClusterError` within about ``timeout``
    seconds (plus at most twice :data:`PROBE_SECONDS` to name what answers instead) when
    ``address`` does not answer as a Dask scheduler, and ``OSError`` when nothing can be
    reached there (refused, unroutable, a TLS handshake refused)."""
    _check_listening(address, timeout)
    if connection_args is None:  # TLS files set in dask's config, as a Client reads them
        from distributed.security import Security

        connection_args = Security().get_connection_args("client")
    with concurrent.futures.ThreadPoolExecutor(1) as pool:  # own event loop, any caller
        future = pool.submit(asyncio.run, _identity(address, timeout, connection_args))
        try:
            reply = future.result(timeout + 5.0)
        except (TimeoutError, concurrent.futures.TimeoutError) as e:
            first = _first_line(address, min(timeout, PROBE_SECONDS))
            said = f" ({_who_answers(first, e)})" if first else ""
            raise ClusterError(f"{address} accepted no Dask handshake within {timeout:g} s"
                               f"{said}: {HINT}") from e
        except OSError:  # the caller says "cannot reach" with its own hints (TLS ...)
            raise
        except Exception as e:  # whatever the bytes were, they were not Dask's
            raise ClusterError(f"{address} does not speak Dask's protocol "
                               f"({_who_answers(_first_line(address), e)}): {HINT}") from e
    if not (isinstance(reply, dict) and reply.get("type") == "Scheduler"):
        kind = reply.get("type") if isinstance(reply, dict) else type(reply).__name__
        raise ClusterError(f"{address} answered as {kind!r}, not as a Dask scheduler: {HINT}")
    return reply
