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

LEARNER_USER = "grader-learner"  # the system user of learner code's own (the Gradescope image's setup.sh creates it)


def learner_ids() -> tuple[int, int, str] | None:
    """(uid, gid, name) of the dedicated user learner code runs as (LEARNER_USER), or None where it does not exist:
    learner code never shares a uid with anything else, so that every process of it can be killed."""
    try:
        import pwd

        entry = pwd.getpwnam(LEARNER_USER)
    except (ImportError, KeyError):
        return None
    return entry.pw_uid, entry.pw_gid, LEARNER_USER


class DroppedUser:
    """A grader.boundary.spawn CommandWrapper: the child's command run as the learner's user, through setpriv. During
    a run the memory of every process of that user together is watched (MemoryWatch); `out_of_memory` says whether
    the last run went over it (and was killed)."""

    available = False  # no private /tmp of its own: the child writes the learner's files to a host folder

    def __init__(self, setpriv: str, memory_bytes: int = 1 << 30) -> None:
        self.setpriv = setpriv
        self.uid, self.gid, self.name = learner_ids()
        self.memory_bytes = memory_bytes
        self.watch: MemoryWatch | None = None
        self.out_of_memory = False

    def __call__(self, command: list[str]) -> list[str]:
        return [self.setpriv, f"--reuid={self.uid}", f"--regid={self.gid}", "--clear-groups", "--inh-caps=-all",
                "--bounding-set=-all", "--", *command]

    def give(self, folder: str) -> None:
        """Let the learner's user write into `folder` (the child's scratch folder on the host)."""
        os.chown(folder, self.uid, self.gid)

    def scratch_dirs(self) -> list[str]:
        return []

    def before_run(self, memory_bytes: int | None = None) -> None:
        """This machine's learner user is this run's alone (other graders here wait), nothing of an earlier run is
        left running as it when a learner's child starts, and the memory of all its processes is watched from now
        (at most `memory_bytes` together, else this user's default)."""
        _machine_lock.take()
        kill_every_process(self.uid, self.gid)
        self.out_of_memory = False
        self.watch = MemoryWatch(self, memory_bytes or self.memory_bytes)

    def after_run(self) -> None:
        """Every process this user runs is killed once a run is over (a process that left the run's process group and
        hops from pid to pid, forking and exiting, too); then another grader here may run learner code as it."""
        try:
            if self.watch is not None:
                self.out_of_memory = self.watch.stop()
                self.watch = None
            kill_every_process(self.uid, self.gid)
        finally:
            _machine_lock.give()

    def describe(self) -> str:
        return (f"isolation: no bubblewrap here; learner code runs as the unprivileged user {self.name} (uid {self.uid},"
                " no groups, no capabilities), never as root, which cannot read the references, keys or course file "
                f"(root's only), with resource limits per process, all its processes together within "
                f"{self.memory_bytes >> 20} MiB "
                f"(watched every {MemoryWatch.SECONDS * 1000:g} ms), its process tree killed on a timeout and every "
                "process of that user killed after each run")


ROUNDS = 200  # kill(-1) rounds before giving up on a user's processes (each new generation is killed in the next)
LOCK_FOLDER = "/run/jacobians-grader"  # root's only: learner code cannot take the lock (nor hold it forever)


class _MachineLock:
    """The learner user is one per machine: a run behind it holds this lock (an flock on a file in a folder only root
    can enter) from before its child starts until every process of that user is killed, so that two graders on one
    machine wait for each other instead of killing each other's learners. Taken again by the same process, counted."""

    def __init__(self) -> None:
        self.fd: int | None = None
        self.depth = 0

    def take(self) -> None:
        if self.depth == 0:
            import fcntl

            os.makedirs(LOCK_FOLDER, mode=0o700, exist_ok=True)
            folder = os.stat(LOCK_FOLDER)
            if folder.st_uid != 0 or stat.S_IMODE(folder.st_mode) & 0o077:
                raise PermissionError(f"{LOCK_FOLDER} must be root's alone (mode 0700): the learner user's lock is in it")
            self.fd = os.open(os.path.join(LOCK_FOLDER, "learner.lock"), os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o600)
            fcntl.flock(self.fd, fcntl.LOCK_EX)
        self.depth += 1

    def give(self) -> None:
        self.depth = max(0, self.depth - 1)
        if self.depth == 0 and self.fd is not None:
            os.close(self.fd)  # the flock goes with it
            self.fd = None


_machine_lock = _MachineLock()


def processes_of(uid: int) -> list[int]:
    """The live processes whose real or effective uid is `uid` (zombies are dead already: they are left out)."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/status", "rb") as handle:
                status = handle.read()
        except OSError:
            continue
        state, uids = b"", []
        for line in status.split(b"\n"):
            if line.startswith(b"State:"):
                state = line.split()[1]
            elif line.startswith(b"Uid:"):
                uids = [int(n) for n in line.split()[1:3]]
        if state != b"Z" and uid in uids:
            found.append(int(entry))
    return found


class MemoryWatch:
    """The memory of every process of the learner user together, looked at every SECONDS from a thread of the
    grader's while a run goes on, as the sandbox's own init looks at its namespace (grader.boundary.confine): over
    `memory_bytes`, every process of that user is killed. (A user's processes share no cgroup of their own in the
    containers this barrier serves: nothing there lets the grader make one.)"""

    SECONDS = 0.02

    def __init__(self, user: DroppedUser, memory_bytes: int) -> None:
        import threading

        self.user, self.memory_bytes, self.exceeded = user, memory_bytes, False
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self._watch, name="learner memory", daemon=True)
        self.thread.start()

    def _watch(self) -> None:
        from grader.boundary.confine import over

        while not self.stopped.wait(self.SECONDS):
            if over(processes_of(self.user.uid), self.memory_bytes):
                self.exceeded = True
                kill_every_process(self.user.uid, self.user.gid)

    def stop(self) -> bool:
        """Stop watching; whether the run went over its memory (and was killed for it)."""
        self.stopped.set()
        self.thread.join()
        return self.exceeded


def kill_every_process(uid: int, gid: int) -> bool:
    """Kill every process of `uid`, from a process that has become `uid` (kill(-1) reaches exactly those: no other
    user's process, no root's), again until none is left; reap what this process adopted. True when none is left.
    Only ever for the dedicated learner user (learner_ids): nothing else runs as it."""
    from grader.boundary.spawn import kill_orphans

    for _ in range(ROUNDS):
        if not processes_of(uid):
            return True
        pid = os.fork()
        if pid == 0:  # a child that does nothing else: drop to the learner's uid, signal all of its processes, exit
            try:
                os.setgroups([])
                os.setgid(gid)
                os.setuid(uid)
                os.kill(-1, 9)
            finally:
                os._exit(0)
        os.waitpid(pid, 0)
        kill_orphans()
    return not processes_of(uid)


def possible() -> str | None:
    """The setpriv to drop privileges with, where this process is root, has one and the dedicated learner user
    exists; else None."""
    if not (hasattr(os, "geteuid") and os.geteuid() == 0) or learner_ids() is None:
        return None
    return shutil.which("setpriv")


def why_impossible() -> str:
    """Why possible() found no way to drop privileges here."""
    if not hasattr(os, "geteuid"):
        return "this system has no user ids to run learner code as another user"
    if os.geteuid() != 0:
        return "the grader does not run as root (with setpriv) to run learner code as an unprivileged user"
    if learner_ids() is None:
        return (f"there is no user {LEARNER_USER} of learner code's own (`useradd --system --no-create-home --shell "
                f"/usr/sbin/nologin {LEARNER_USER}` makes it; nothing else may share its uid)")
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
