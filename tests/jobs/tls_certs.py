"""Throw-away TLS material for tests: a CA and one certificate/key it signed (PEM files).

Made with ``cryptography`` (installed with distributed). The certificate names localhost
and 127.0.0.1 and has no extended-key-usage restriction, so one certificate serves a
scheduler, a worker and a client, as the farm's embedded TLS cluster uses it.
"""

from __future__ import annotations

import datetime
import ipaddress
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

VALID = datetime.timedelta(days=1)


def _name(common_name: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name)])


def _builder(subject: str, issuer: x509.Name, public_key) -> x509.CertificateBuilder:
    now = datetime.datetime.now(datetime.UTC)
    return (x509.CertificateBuilder().subject_name(_name(subject)).issuer_name(issuer)
            .public_key(public_key).serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5)).not_valid_after(now + VALID))


def make_certificates(folder: Path, prefix: str = "") -> tuple[Path, Path, Path]:
    """Write ``<prefix>ca.pem``, ``<prefix>cert.pem`` and ``<prefix>key.pem`` (a new CA
    each call) into ``folder``; return their paths."""
    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca = (_builder(f"{prefix}test-ca", _name(f"{prefix}test-ca"), ca_key.public_key())
          .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
          .sign(ca_key, hashes.SHA256()))
    key = ec.generate_private_key(ec.SECP256R1())
    names = [x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]
    cert = (_builder("localhost", ca.subject, key.public_key())
            .add_extension(x509.SubjectAlternativeName(names), critical=False)
            .sign(ca_key, hashes.SHA256()))
    paths = tuple(folder / f"{prefix}{name}.pem" for name in ("ca", "cert", "key"))
    paths[0].write_bytes(ca.public_bytes(serialization.Encoding.PEM))
    paths[1].write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    paths[2].write_bytes(key.private_bytes(serialization.Encoding.PEM,
                                           serialization.PrivateFormat.PKCS8,
                                           serialization.NoEncryption()))
    paths[2].chmod(0o600)
    return paths
