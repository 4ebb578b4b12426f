"""Confine one learner's run: fresh user, mount, IPC and PID namespaces, a fresh /tmp, caps on processes
and on the memory of all the learner's processes together. Runs in the child, inside the sandbox,
before any learner code (Linux; elsewhere, or where user namespaces are not allowed, it does nothing
and says so).

    enter(limits) -> str          # in the child; returns how it is confined ("" when it is not)

After `enter` returns, this process is the learner's, alone with its descendants in namespaces of its
own. Above it wait two processes of the grader's: the one that called `enter` (still in the old
namespaces, it passes the exit status up) and the new PID namespace's init, which reaps orphans,
watches the memory of every process in the namespace and, when the learner's process ends, ends, so
that the kernel kills whatever the learner left running. Nothing survives into the next learner's
run: not a process, not a file in /tmp or /dev/shm, not a SysV IPC object, not a key in the user's
keyring (keyrings belong to the user namespace).
"""

from __future__ import annotations

import ctypes
import errno
import os
import signal
import time

CLONE_NEWNS, CLONE_NEWIPC, CLONE_NEWUSER, CLONE_NEWPID = 0x00020000, 0x08000000, 0x10000000, 0x20000000
MS_REC, MS_PRIVATE, MS_NOSUID, MS_NODEV, MS_BIND = 0x4000, 0x40000, 0x2, 0x4, 0x1000
PR_SET_PDEATHSIG, PR_SET_DUMPABLE, PR_CAPBSET_DROP, PR_SET_NO_NEW_PRIVS = 1, 4, 24, 38
_CAPABILITY_VERSION_3 = 0x20080522
OUT_OF_MEMORY = 86  # the exit status of a run whose processes together used more memory than allowed
_POLL_SECONDS = 0.02


class NotConfined(OSError):
    """The kernel did not allow the namespaces (the message says which step)."""


def _libc():
    return ctypes.CDLL(None, use_errno=True)


def _check(result: int, what: str) -> None:
    if result != 0:
        code = ctypes.get_errno()
        raise NotConfined(code, f"{what}: {errno.errorcode.get(code, code)}")


def _namespaces(libc) -> None:
    uid, gid = os.getuid(), os.getgid()
    _check(libc.unshare(CLONE_NEWUSER | CLONE_NEWNS | CLONE_NEWIPC | CLONE_NEWPID), "unshare")
    for name, text in (("setgroups", "deny"), ("uid_map", f"{uid} {uid} 1"), ("gid_map", f"{gid} {gid} 1")):
        with open(f"/proc/self/{name}", "w", encoding="ascii") as handle:
            handle.write(text)


def _outermost(paths: list[str]) -> list[str]:
    out: list[str] = []
    for path in sorted(paths, key=len):
        if not any(path == p or path.startswith(p + "/") for p in out):
            out.append(path)
    return out


def _mounts(libc, tmp_bytes: int, keep: list[str]) -> None:
    """A fresh /tmp and /dev/shm. What the grader needs from below them (a venv under /tmp: `keep`, the
    import path) is bound back from descriptors opened before the fresh tmpfs covers it (read-only as
    it was)."""
    _check(libc.mount(b"none", b"/", None, MS_REC | MS_PRIVATE, None), "make mounts private")
    for target, size in (("/tmp", tmp_bytes), ("/dev/shm", min(tmp_bytes, 16 << 20))):
        if not os.path.isdir(target):
            continue
        below = _outermost([p for p in keep if p.startswith(target + "/") and os.path.exists(p)])
        handles = [os.open(p, os.O_PATH) for p in below]
        options = f"size={size},mode=1777".encode()
        _check(libc.mount(b"tmpfs", target.encode(), b"tmpfs", MS_NOSUID | MS_NODEV, options), f"mount {target}")
        for path, handle in zip(below, handles):
            os.makedirs(path, exist_ok=True)
            _check(libc.mount(f"/proc/self/fd/{handle}".encode(), path.encode(), None, MS_BIND | MS_REC, None),
                   f"bind {path}")
            os.close(handle)


class _CapHeader(ctypes.Structure):
    _fields_ = [("version", ctypes.c_uint32), ("pid", ctypes.c_int)]


class _CapData(ctypes.Structure):
    _fields_ = [("effective", ctypes.c_uint32), ("permitted", ctypes.c_uint32), ("inheritable", ctypes.c_uint32)]


def _drop_capabilities(libc) -> None:
    """The creator of a user namespace holds every capability in it: learner code gets none (it could
    otherwise unmount its fresh /tmp, for one)."""
    for capability in range(64):
        libc.prctl(PR_CAPBSET_DROP, capability, 0, 0, 0)
    header, data = _CapHeader(_CAPABILITY_VERSION_3, 0), (_CapData * 2)()
    _check(libc.capset(ctypes.byref(header), data), "capset")
    _check(libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0), "no_new_privs")


def _namespace_pids(own_ns: str) -> list[int]:
    """The pids (as /proc shows them) of every process in the PID namespace `own_ns`, whose init this process
    is: its descendants (every process of a PID namespace descends from its init), read from the kernel's
    lists of children, which costs a file per process instead of a look at every process of the machine.
    Where the kernel keeps no such lists, every process is looked at."""
    if not os.path.exists("/proc/thread-self/children"):  # a kernel without CONFIG_PROC_CHILDREN
        return _scanned_pids(own_ns)
    found, todo = [], [int(os.readlink("/proc/self"))]
    while todo:
        pid = todo.pop()
        found.append(pid)
        try:
            for tid in os.listdir(f"/proc/{pid}/task"):
                with open(f"/proc/{pid}/task/{tid}/children", "rb") as handle:
                    todo.extend(int(child) for child in handle.read().split())
        except OSError:  # it, or one of its threads, ended meanwhile
            continue
    return found


def _scanned_pids(own_ns: str) -> list[int]:
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                if os.readlink(f"/proc/{entry}/ns/pid") == own_ns:
                    found.append(int(entry))
            except OSError:
                continue
    return found


def resident_bytes(pids: list[int]) -> int:
    page = os.sysconf("SC_PAGE_SIZE")
    total = 0
    for pid in pids:
        try:
            with open(f"/proc/{pid}/statm", "rb") as handle:
                total += int(handle.read().split()[1]) * page
        except (OSError, ValueError, IndexError):
            continue
    return total


def proportional_bytes(pids: list[int]) -> int:
    """Their memory with shared pages split between the processes that share them (PSS): the forked
    copies of one interpreter share most of their pages, which their resident sizes count again each."""
    total = 0
    for pid in pids:
        try:
            with open(f"/proc/{pid}/smaps_rollup", "rb") as handle:
                for line in handle:
                    if line.startswith(b"Pss:"):
                        total += int(line.split()[1]) * 1024
                        break
        except (OSError, ValueError, IndexError):
            total += resident_bytes([pid])
    return total


def over(pids: list[int], memory_bytes: int) -> bool:
    """Whether the processes `pids` together use more than memory_bytes (the cheap resident sizes first, which can
    only overstate; the proportional sizes when they say so)."""
    return resident_bytes(pids) > memory_bytes and proportional_bytes(pids) > memory_bytes


def _init(learner: int, memory_bytes: int | None) -> None:
    """PID 1 of the learner's namespace: reap, watch memory, and end when the learner's process ends."""
    own_ns = os.readlink("/proc/self/ns/pid")
    while True:
        try:
            pid, status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            os._exit(70)
        if pid == learner:
            os._exit(os.waitstatus_to_exitcode(status) & 0xFF if os.WIFEXITED(status)
                     else 128 + os.WTERMSIG(status))
        if pid:
            continue  # an orphan reaped; look again at once
        if memory_bytes is not None and over(_namespace_pids(own_ns), memory_bytes):
            os.kill(-1, signal.SIGKILL)  # every process of the namespace but this one
            os._exit(OUT_OF_MEMORY)
        time.sleep(_POLL_SECONDS)


def enter(limits: dict, keep: list[str]) -> str:
    """Confine the rest of this process's life (see the module's docstring); "" when not possible here.
    `keep`: folders the grader still needs (its import path), kept visible under the fresh /tmp."""
    if not hasattr(os, "fork") or not os.path.isdir("/proc/self/ns"):
        return ""
    libc = _libc()
    try:
        _namespaces(libc)
    except (NotConfined, OSError):
        return ""
    first = os.fork()
    if first:  # still in the old PID namespace: wait for the new one's init and pass its status up
        _, status = os.waitpid(first, 0)
        os._exit(os.waitstatus_to_exitcode(status) & 0xFF if os.WIFEXITED(status) else 128 + os.WTERMSIG(status))
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)  # pid 1: gone with the grader above it
    try:
        _mounts(libc, int(limits.get("tmp_bytes") or 64 << 20), keep)
    except NotConfined:
        os._exit(71)
    learner = os.fork()
    if learner:
        libc.prctl(PR_SET_DUMPABLE, 0, 0, 0, 0)  # learner code (same uid) cannot ptrace pid 1
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        _init(learner, limits.get("memory_bytes"))
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    try:
        _drop_capabilities(libc)
    except NotConfined:
        os._exit(71)
    return (f"own namespaces, /tmp of {int(limits.get('tmp_bytes') or 64 << 20) >> 20} MiB, "
            f"all processes together within {(limits.get('memory_bytes') or 0) >> 20} MiB")
