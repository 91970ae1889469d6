"""Dask scheduler addresses: ``[scheme://]host:port`` with a scheme the farm's workers talk.

Checked before anything is solved, by the CLI's ``--scheduler`` and by the cluster code
(:mod:`jobs.cluster`); whether the address answers is :mod:`jobs.handshake`'s question.
"""

from __future__ import annotations

import ipaddress
import re

from jobs.validate.messages import fail, shown

SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "inproc")
# ucx:// needs ucx-py and RDMA hardware that the farm does not install or test; it was
# accepted here and then failed deep in distributed with a TypeError (issue 26)
UNSUPPORTED_SCHEMES = {"ucx": "UCX (ucx://) is not supported by the farm: its workers talk "
                              "tcp:// or tls://"}
HOSTNAME = re.compile(r"(?=.{1,253}$)[A-Za-z0-9_]([A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?"
                      r"(\.[A-Za-z0-9_]([A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?)*")


def scheduler_address(value: str | None, where: str = "--scheduler") -> str | None:
    """A Dask scheduler address: ``[scheme://]host:port`` with a scheme of
    :data:`SCHEDULER_SCHEMES` (tcp when none is given), a host name, IPv4 or [IPv6]
    address and a port in 1-65535; or ``inproc://...``. ``None`` (embedded) passes."""
    if value is None:
        return None
    hint = "give host:port or tcp://host:port (e.g. tcp://127.0.0.1:8786)"
    scheme, sep, rest = value.partition("://")
    if not sep:
        scheme, rest = "tcp", value
    if scheme in UNSUPPORTED_SCHEMES:
        raise fail(where, f"{UNSUPPORTED_SCHEMES[scheme]}: {hint}")
    if scheme not in SCHEDULER_SCHEMES:
        raise fail(where, f"unknown protocol {shown(scheme)} in {shown(value)}; use one of "
                   f"{', '.join(SCHEDULER_SCHEMES)}: {hint}")
    if scheme == "inproc":
        if not re.fullmatch(r"[\w.:/-]{1,256}", rest):
            raise fail(where, f"{shown(value)} is not an inproc address (inproc://host/pid/n)")
        return value
    host, colon, port = rest.rpartition(":")
    if not colon or not _is_host(host) or not (port.isdigit() and 1 <= int(port) <= 65535):
        raise fail(where, f"{shown(value)} is not a scheduler address: {hint}")
    return value


def _is_host(host: str) -> bool:
    if host.startswith("[") and host.endswith("]"):
        try:
            ipaddress.IPv6Address(host[1:-1])
        except ValueError:
            return False
        return True
    return bool(HOSTNAME.fullmatch(host))
