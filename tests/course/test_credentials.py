"""The cluster's credentials (grader.course.credentials): made by `grade cluster certs`, their owner's only, refused
where others can read a key; and what they admit (tests/course/test_cluster.py, on a real scheduler)."""

from __future__ import annotations

import socket
import stat
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("cryptography", reason="the [cluster] extra (CI installs it with the test extras)")


def grade(*args, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "grader", *map(str, args)], cwd=cwd, capture_output=True, text=True,
                          encoding="utf-8", timeout=300, check=False)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_the_clusters_certificates_are_their_owners_only(tmp_path):
    """`grade cluster certs` writes the authority and a certificate per role into a folder only its owner enters, each
    role's file (its private key) readable by its owner only; a key others can read is refused, saying how to fix
    it; a second run does not replace them unless --force."""
    from grader.course import credentials

    made = grade("cluster", "certs", tmp_path / "certs", cwd=tmp_path)
    assert made.returncode == 0, made.stderr
    certs = tmp_path / "certs"
    assert "coordinator.pem    for grade batch --scheduler tls://SCHEDULER:8786 --certs" in made.stdout
    assert sorted(p.name for p in certs.iterdir()) == ["ca.pem", "coordinator.pem", "scheduler.pem", "worker.pem"]
    assert stat.S_IMODE(certs.stat().st_mode) == 0o700
    for role in ("coordinator", "scheduler", "worker"):
        assert stat.S_IMODE((certs / f"{role}.pem").stat().st_mode) == 0o600
        assert "PRIVATE KEY" in (certs / f"{role}.pem").read_text(encoding="utf-8")
    assert "PRIVATE KEY" not in (certs / "ca.pem").read_text(encoding="utf-8")
    again = grade("cluster", "certs", certs, cwd=tmp_path)
    assert again.returncode != 0 and "--force" in again.stderr
    (certs / "worker.pem").chmod(0o640)
    with pytest.raises(credentials.CredentialsError, match=r"worker.pem holds a private key and can be read by others "
                                                            r"\(mode 640\): `chmod 600"):
        credentials.security(certs, "worker")
    done = grade("worker", f"tls://127.0.0.1:{free_port()}", "--certs", certs, cwd=tmp_path)
    assert done.returncode == 2 and "can be read by others (mode 640)" in done.stderr


def test_a_certificate_signed_by_the_course_authority_is_accepted_and_one_of_another_is_not(tmp_path):
    """Each role's certificate verifies against the course's ca.pem, as Dask's TLS verifies it (ssl, the peer's
    certificate required); another run's certificate does not."""
    import ssl

    from grader.course import credentials

    credentials.make(tmp_path / "course")
    credentials.make(tmp_path / "other")
    for role in credentials.ROLES:
        context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH, cafile=str(tmp_path / "course" / "ca.pem"))
        context.load_cert_chain(str(tmp_path / "course" / f"{role}.pem"))  # the key matches the certificate
    from cryptography import x509
    from cryptography.exceptions import InvalidSignature

    authority = x509.load_pem_x509_certificate((tmp_path / "course" / "ca.pem").read_bytes())
    for folder, signed in (("course", True), ("other", False)):
        for role in credentials.ROLES:
            certificate = x509.load_pem_x509_certificate((tmp_path / folder / f"{role}.pem").read_bytes())
            try:
                certificate.verify_directly_issued_by(authority)
                verified = True
            except (InvalidSignature, ValueError):
                verified = False
            assert verified is signed, (folder, role)
