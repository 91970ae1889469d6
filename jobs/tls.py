"""Dask TLS: the certificate files of ``--tls-ca-file/--tls-cert/--tls-key``, checked once.

Users on shared clusters run the scheduler with TLS (``tls://host:8786``): every endpoint
proves who it is with a certificate signed by the cluster's CA, and all traffic is
encrypted (dask's docs, "TLS/SSL"). Without it anyone who reaches the scheduler port runs
code on the workers. The farm connects with
``Security(tls_ca_file=..., tls_client_cert=..., tls_client_key=..., require_encryption=True)``.

Two routes give the files:

- options: :class:`TlsFiles` (all three or none, each an existing readable regular file);
- dask's own configuration, e.g. ``DASK_DISTRIBUTED__COMM__TLS__CA_FILE``,
  ``DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT`` and ``..._CLIENT__KEY`` or the same keys
  in a dask YAML file: a ``distributed.Client`` reads them itself (:func:`configured`).

The embedded LocalCluster runs encrypted when files are given: scheduler, workers and
client all present the given certificate (so it must be valid as server and as client,
which a certificate without an extended-key-usage restriction is). Without files it runs
on plain TCP bound to 127.0.0.1, which only this machine reaches.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import dask

from jobs.errors import ClusterError

TLS_SCHEME = "tls://"
OPTION_NAMES = ("--tls-ca-file", "--tls-cert", "--tls-key")
CONFIG_KEYS = ("distributed.comm.tls.ca-file", "distributed.comm.tls.client.cert",
               "distributed.comm.tls.client.key")
ENV_HINT = ("DASK_DISTRIBUTED__COMM__TLS__CA_FILE, DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT "
            "and DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY")


def check_file(path: str | os.PathLike, option: str) -> Path:
    """``path`` if it is an existing, regular, readable file; else a one-line error."""
    p = Path(path).expanduser()
    if not p.exists():
        raise ClusterError(f"{option}: {str(path)!r} does not exist: give the path of a PEM "
                           "file")
    if not p.is_file():
        raise ClusterError(f"{option}: {str(path)!r} is not a regular file: give the path of "
                           "a PEM file")
    if not os.access(p, os.R_OK):
        raise ClusterError(f"{option}: {str(path)!r} is not readable by this user: fix its "
                           "permissions (chmod u+r)")
    return p.resolve()


@dataclass(frozen=True)
class TlsFiles:
    """The CA certificate, and this endpoint's certificate and private key (PEM files)."""

    ca_file: Path
    cert: Path
    key: Path

    def __post_init__(self) -> None:
        for name, option in zip(("ca_file", "cert", "key"), OPTION_NAMES, strict=True):
            object.__setattr__(self, name, check_file(getattr(self, name), option))

    @classmethod
    def from_options(cls, ca_file: str | os.PathLike | None, cert: str | os.PathLike | None,
                     key: str | os.PathLike | None) -> TlsFiles | None:
        """The three options' files, ``None`` when none is given; an error for some."""
        given = [v is not None for v in (ca_file, cert, key)]
        if not any(given):
            return None
        if ca_file is None or cert is None or key is None:
            missing = [o for o, g in zip(OPTION_NAMES, given, strict=True) if not g]
            raise ClusterError(f"TLS needs all of {', '.join(OPTION_NAMES)}: "
                               f"{', '.join(missing)} missing; give all three or none")
        # __post_init__ checks each file (check_file: expanded and resolved)
        return cls(Path(ca_file), Path(cert), Path(key))

    def dask_config(self) -> dict[str, Any]:
        """These files as dask configuration: a ``Client`` made inside
        ``dask.config.set(...)`` of it connects with them (and only encrypted)."""
        return {**dict(zip(CONFIG_KEYS, map(str, (self.ca_file, self.cert, self.key)),
                           strict=True)), "distributed.comm.require-encryption": True}

    def client_security(self) -> Any:
        """A ``distributed.security.Security`` for a client of a TLS scheduler."""
        from distributed.security import Security

        return Security(tls_ca_file=str(self.ca_file), tls_client_cert=str(self.cert),
                        tls_client_key=str(self.key), require_encryption=True)

    def cluster_security(self) -> Any:
        """A ``Security`` for a whole embedded cluster (every endpoint, this certificate)."""
        from distributed.security import Security

        files = {f"tls_{role}_{part}": str(path) for role in ("client", "scheduler", "worker")
                 for part, path in (("cert", self.cert), ("key", self.key))}
        return Security(tls_ca_file=str(self.ca_file), require_encryption=True, **files)


def configured() -> bool:
    """True if dask's configuration (env ``DASK_DISTRIBUTED__COMM__TLS__*`` or YAML) names
    a CA file and a client certificate: a ``Client`` then speaks TLS by itself."""
    return all(dask.config.get(k, None) for k in CONFIG_KEYS[:2])


def check_address(address: str | None, tls: TlsFiles | None) -> None:
    """Refuse a scheduler address that does not match the TLS settings, in one line.

    ``address`` is the resolved one (``None``: embedded cluster, fine either way).
    """
    if address is None:
        return
    wants_tls = address.startswith(TLS_SCHEME)
    if tls is not None and not wants_tls:
        raise ClusterError(f"TLS certificates were given but the scheduler address {address!r} "
                           "is not tls://: give it as tls://host:port, or drop the --tls-* "
                           "options")
    if wants_tls and tls is None and not configured():
        raise ClusterError(f"the scheduler {address!r} speaks TLS but no certificates were "
                           f"given: add {', '.join(OPTION_NAMES)} (or set {ENV_HINT})")
