"""The barrier where bubblewrap cannot start but the grader runs as root (Gradescope's usual container): learner
code runs as a dedicated unprivileged user, its uid and gid dropped with no supplementary groups and no
capabilities (setpriv), while the references, the keys and the course's file are readable by root only. Per-uid
limits (RLIMIT_NPROC and the others, set by the child) hold for that user.

A barrier only where it holds: grader.boundary.door.choose proves it before grading, with an interpreter started
as that user that must import numpy and the child's side and must fail to read every secret path it is given.
"""

from __future__ import annotations

import os
import shutil
import stat
from pathlib import Path

LEARNER_USER = "grader-learner"  # the system user the Gradescope image's setup.sh creates; else nobody
NOBODY = 65534


def learner_ids() -> tuple[int, int, str]:
    """(uid, gid, name) of the user learner code runs as: LEARNER_USER where it exists, else nobody."""
    try:
        import pwd

        entry = pwd.getpwnam(LEARNER_USER)
        return entry.pw_uid, entry.pw_gid, LEARNER_USER
    except (ImportError, KeyError):
        return NOBODY, NOBODY, "nobody"


class DroppedUser:
    """A grader.boundary.spawn CommandWrapper: the child's command run as the learner's user, through setpriv."""

    available = False  # no private /tmp of its own: the child writes the learner's files to a host folder

    def __init__(self, setpriv: str) -> None:
        self.setpriv = setpriv
        self.uid, self.gid, self.name = learner_ids()

    def __call__(self, command: list[str]) -> list[str]:
        return [self.setpriv, f"--reuid={self.uid}", f"--regid={self.gid}", "--clear-groups", "--inh-caps=-all",
                "--bounding-set=-all", "--", *command]

    def give(self, folder: str) -> None:
        """Let the learner's user write into `folder` (the child's scratch folder on the host)."""
        os.chown(folder, self.uid, self.gid)

    def scratch_dirs(self) -> list[str]:
        return []

    def describe(self) -> str:
        return (f"isolation: no bubblewrap here; learner code runs as the unprivileged user {self.name} (uid {self.uid},"
                " no groups, no capabilities), which cannot read the references, keys or course file (root's only), "
                "with resource limits per learner and its process tree killed on a timeout")


def possible() -> str | None:
    """The setpriv to drop privileges with, where this process is root and has one; else None."""
    if not (hasattr(os, "geteuid") and os.geteuid() == 0):
        return None
    return shutil.which("setpriv")


def why_impossible() -> str:
    """Why possible() found no way to drop privileges here."""
    if not hasattr(os, "geteuid"):
        return "this system has no user ids to run learner code as another user"
    if os.geteuid() != 0:
        return "the grader does not run as root (with setpriv) to run learner code as an unprivileged user"
    return "setpriv (util-linux) is not installed, to run learner code as an unprivileged user"


def root_only(paths: list[Path]) -> None:
    """Make `paths` (files, or folders with all they hold) readable by root only (this process is root)."""
    for path in paths:
        if not path.exists():
            continue
        places = [path] if not path.is_dir() else [path, *path.rglob("*")]
        for place in places:
            if place.is_symlink():
                continue
            mode = place.stat().st_mode
            place.chmod(stat.S_IMODE(mode) & ~0o077)
