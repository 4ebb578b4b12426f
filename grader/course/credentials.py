"""The cluster's credentials: a certificate authority of the course's own and a certificate for each role (the
scheduler, the workers, the coordinator that runs `grade batch`), so that Dask's scheduler, workers and clients
accept only one another (mutual TLS: each side shows a certificate the course's authority signed).

`grade cluster certs DIR` makes them (cryptography, which Dask's own TLS uses): DIR/ca.pem, the authority's
certificate, and DIR/ROLE.pem, a role's certificate followed by its private key, readable by their owner only.
The authority's own key is never written: run it again (--force) for a new set. Each machine gets ca.pem and
its role's file; whoever holds a role's file can join the cluster as anyone, so it is kept where only the
grader's account (root, or the worker's user) reads it, never where learner code runs.
"""

from __future__ import annotations

import datetime
import os
import stat
from pathlib import Path

ROLES = ("scheduler", "worker", "coordinator")
AUTHORITY = "ca.pem"
DASK_ROLE = {"scheduler": "scheduler", "worker": "worker", "coordinator": "client"}  # Security's name of each role


class CredentialsError(RuntimeError):
    """The credentials cannot be made or used as they are: the message names the file and what to do."""


def role_file(folder: Path, role: str) -> Path:
    """Where `role`'s certificate and key are in `folder`."""
    if role not in ROLES:
        raise ValueError(f"role must be one of {ROLES}, not {role!r}")
    return folder / f"{role}.pem"


def make(folder: Path, days: int = 365, force: bool = False) -> list[Path]:
    """A new authority and a certificate for each role, written into `folder` (made readable by its owner only);
    CredentialsError where `folder` holds credentials already and `force` is not given. Returns the files."""
    try:
        from cryptography import x509
        from cryptography.hazmat.primitives import hashes, serialization
        from cryptography.hazmat.primitives.asymmetric import ec
        from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID
    except ImportError:
        raise CredentialsError("making the cluster's certificates needs cryptography: pip install "
                               "'jacobians-grader[cluster]'") from None
    targets = [folder / AUTHORITY, *(role_file(folder, role) for role in ROLES)]
    present = [path.name for path in targets if path.exists()]
    if present and not force:
        raise CredentialsError(f"{folder} holds {', '.join(present)} already: pass --force to replace them (every "
                               "machine of the cluster then needs the new files)")
    folder.mkdir(parents=True, exist_ok=True)
    if hasattr(os, "geteuid"):
        folder.chmod(0o700)
    now = datetime.datetime.now(datetime.timezone.utc)
    valid = (now - datetime.timedelta(minutes=5), now + datetime.timedelta(days=days))

    def name(common: str) -> x509.Name:
        return x509.Name([x509.NameAttribute(NameOID.ORGANIZATION_NAME, "jacobians-grader cluster"),
                          x509.NameAttribute(NameOID.COMMON_NAME, common)])

    authority_key = ec.generate_private_key(ec.SECP256R1())
    authority = (x509.CertificateBuilder().subject_name(name("the course's cluster authority"))
                 .issuer_name(name("the course's cluster authority")).public_key(authority_key.public_key())
                 .serial_number(x509.random_serial_number()).not_valid_before(valid[0]).not_valid_after(valid[1])
                 .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
                 .add_extension(x509.KeyUsage(digital_signature=False, content_commitment=False, key_encipherment=False,
                                              data_encipherment=False, key_agreement=False, key_cert_sign=True,
                                              crl_sign=True, encipher_only=False, decipher_only=False), critical=True)
                 .sign(authority_key, hashes.SHA256()))
    written = [_write(folder / AUTHORITY, authority.public_bytes(serialization.Encoding.PEM), 0o644)]
    for role in ROLES:
        key = ec.generate_private_key(ec.SECP256R1())
        certificate = (x509.CertificateBuilder().subject_name(name(f"grader {role}")).issuer_name(authority.subject)
                       .public_key(key.public_key()).serial_number(x509.random_serial_number())
                       .not_valid_before(valid[0]).not_valid_after(valid[1])
                       .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
                       .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH,
                                                             ExtendedKeyUsageOID.CLIENT_AUTH]), critical=False)
                       .sign(authority_key, hashes.SHA256()))
        private = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                    serialization.NoEncryption())
        written.append(_write(role_file(folder, role), certificate.public_bytes(serialization.Encoding.PEM) + private,
                              0o600))
    return written


def _write(path: Path, data: bytes, mode: int) -> Path:
    """`data` into `path`, created with `mode` (never readable by others even for an instant), replacing it."""
    partial = path.with_name(f".{path.name}.partial")
    partial.unlink(missing_ok=True)
    handle = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), mode)
    with os.fdopen(handle, "wb") as written:
        written.write(data)
    os.replace(partial, path)
    return path


def checked(folder: Path, role: str) -> tuple[Path, Path]:
    """(the authority's certificate, `role`'s file) in `folder`, each present and the role's file readable by its
    owner only (as ssh asks of a private key); CredentialsError naming the file and the fix otherwise."""
    folder = folder.expanduser().resolve()
    authority, own = folder / AUTHORITY, role_file(folder, role)
    for path in (authority, own):
        if not path.is_file():
            raise CredentialsError(f"{path} does not exist: `grade cluster certs {folder}` makes the cluster's "
                                   f"certificates, then copy {AUTHORITY} and {own.name} to this machine")
    if hasattr(os, "geteuid"):
        mode = stat.S_IMODE(own.stat().st_mode)
        if mode & 0o077:
            raise CredentialsError(f"{own} holds a private key and can be read by others (mode {mode:03o}): "
                                   f"`chmod 600 {own}` (whoever reads it joins the cluster as anyone)")
    return authority, own


def security(folder: Path | str, *roles: str, client: str | None = None):
    """Dask's distributed.Security for `roles` of the credentials in `folder` (checked), encryption required
    (no plain connection is made or accepted); `client`: the role whose certificate a Client made with it shows
    (a worker's, checking the scheduler before it joins)."""
    from distributed.security import Security

    folder = Path(folder).expanduser()
    files: dict = {}
    for role, dask_role in [(role, DASK_ROLE[role]) for role in roles] + ([(client, "client")] if client else []):
        authority, own = checked(folder, role)
        files.update({"tls_ca_file": str(authority), f"tls_{dask_role}_cert": str(own), f"tls_{dask_role}_key": str(own)})
    return Security(require_encryption=True, **files)


def dask_options(folder: Path | str, role: str) -> list[str]:
    """`dask scheduler` and `dask worker`'s TLS options for `role` of the credentials in `folder` (checked)."""
    authority, own = checked(Path(folder).expanduser(), role)
    return ["--tls-ca-file", str(authority), "--tls-cert", str(own), "--tls-key", str(own)]


def require_encryption_environment() -> dict[str, str]:
    """The environment that makes a Dask process refuse every unencrypted connection (Dask's
    distributed.comm.require-encryption)."""
    return {"DASK_DISTRIBUTED__COMM__REQUIRE_ENCRYPTION": "True"}


def describe(written: list[Path]) -> str:
    """What `grade cluster certs` made, and where each file goes."""
    folder = written[0].parent
    return "\n".join([
        f"The cluster's credentials, in {folder} (readable by you only):",
        f"  {AUTHORITY}             the course's authority (every machine)",
        f"  scheduler.pem      for the scheduler: grade cluster scheduler --certs {folder}",
        f"  worker.pem         for each worker machine: grade worker tls://SCHEDULER:8786 --certs {folder}",
        f"  coordinator.pem    for grade batch --scheduler tls://SCHEDULER:8786 --certs {folder}",
        "Copy to each machine only ca.pem and its role's file, readable by the grader's account only (chmod 600); "
        "whoever holds one joins the cluster. The authority's key was not kept: run again with --force for a new set.",
    ])
