"""What this system offers a process that starts others: facts, read from the running interpreter, never
from the system's name. A leaf: the learner's boundary (grader.boundary), the grader's own helper processes
(grader.helpers) and the HTML report's drawing processes all read them here; which launcher learner code
gets is decided from them in one place, grader.boundary.door.choose.

Only os and sys at import: grader.faces.launch starts the child before the heavy imports (click, numpy), and the
child's own side (grader.boundary.child, the fork server) imports this inside the sandbox.
"""

from __future__ import annotations

import os
import sys

GRADER_PARENT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# numpy on matrices of a few rows gains nothing from a BLAS thread pool, and OpenBLAS' idle threads
# busy-wait: in the grader they would spin beside the learner's child on the same cores.
SINGLE_THREADED_BLAS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def process_groups() -> bool:
    """Whether children can get process groups of their own and inherited descriptors (POSIX: not Windows)."""
    return hasattr(os, "killpg") and hasattr(os, "setsid") and hasattr(os, "fork")


def fork_is_safe() -> bool:
    """Whether a process that has loaded numpy may fork here (a fork server, the HTML report's drawing): fork
    and descriptors over Unix sockets in sequenced-packet pairs exist, and multiprocessing does not default to
    "spawn" (macOS does: fork after its system libraries is unsafe there)."""
    import multiprocessing
    import socket

    return (hasattr(os, "fork") and hasattr(socket, "send_fds") and hasattr(socket, "AF_UNIX")
            and hasattr(socket, "SOCK_SEQPACKET") and multiprocessing.get_start_method(allow_none=False) != "spawn")


def forkable_now() -> bool:
    """Whether this process may fork now (a drawing process, the warm judge): forking is safe on this system
    (fork_is_safe) and no other thread runs (a fork copies only the calling thread: one holding a lock, an
    import's among them, would leave it held in the copy)."""
    import threading

    return fork_is_safe() and threading.active_count() == 1


def keep_only(descriptor: int) -> None:
    """In a process the grader forked for itself (a drawing process, the warm judge): its standard streams to the
    null device and every other descriptor closed but `descriptor` (no copy of a pipe to the learner's child or of
    the command's output stays open in it)."""
    null = os.open(os.devnull, os.O_RDWR)
    for standard in (0, 1, 2):
        os.dup2(null, standard)
    os.closerange(3, descriptor)
    os.closerange(descriptor + 1, 1 << 16)


def child_path() -> list[str]:
    """A grader interpreter's sys.path: this interpreter's library folders (not the cwd), then grader's parent."""
    paths = [p for p in sys.path if p and os.path.isabs(p) and p != GRADER_PARENT]
    return [*paths, GRADER_PARENT]


def child_environment() -> dict:
    """The environment of every interpreter the grader starts: no PYTHONPATH, one BLAS thread, a fixed hash
    seed."""
    env = {k: os.environ[k] for k in ("PATH", "LANG", "LC_ALL", "SYSTEMROOT") if k in os.environ}
    env.update(SINGLE_THREADED_BLAS, PYTHONHASHSEED="0", PYTHONDONTWRITEBYTECODE="1")
    return env


def temp_dir() -> str:
    """The folder for temporary files: TMPDIR, TEMP or TMP where it exists, else /tmp, else Python's choice."""
    for name in ("TMPDIR", "TEMP", "TMP"):
        if os.path.isdir(os.environ.get(name, "")):
            return os.environ[name]
    if os.path.isdir("/tmp"):
        return "/tmp"
    import tempfile

    return tempfile.gettempdir()


MEMORY_FOLDER = "/dev/shm"  # Linux's folder in memory (a tmpfs)
MEMORY_FOLDER_FREE = 256 << 20  # bytes it must have free to be used: a container's may be small (Docker's: 64 MiB)


def memory_temp_dir() -> str:
    """The folder for small temporary files rewritten often (a batch worker's learner after learner): temp_dir() where
    TMPDIR, TEMP or TMP names one (the machine's owner chose it), else in memory where the system has a folder there
    with MEMORY_FOLDER_FREE bytes free (rewriting a file there costs a tenth of what it costs on a journalled disk;
    a batch's workers put at most staging.MAX_TOTAL_BYTES there each), else temp_dir()."""
    chosen = any(os.path.isdir(os.environ.get(name, "")) for name in ("TMPDIR", "TEMP", "TMP"))
    if not chosen and hasattr(os, "statvfs") and os.path.isdir(MEMORY_FOLDER) and \
            os.access(MEMORY_FOLDER, os.W_OK | os.X_OK):
        try:
            found = os.statvfs(MEMORY_FOLDER)
        except OSError:
            return temp_dir()
        if found.f_bavail * found.f_frsize >= MEMORY_FOLDER_FREE:
            return MEMORY_FOLDER
    return temp_dir()


# ------------------------------------------------------------------------------ the grader's own processes

_KEPT: set[int] = set()  # pids of processes started by the grader itself and not yet ended


def keep(pid: int) -> None:
    """A process of the grader's own (a learner's child while it runs, the report's drawing process): the
    boundary's clean-up of orphans (grader.boundary.spawn.kill_orphans) leaves it alone until forget(pid)."""
    _KEPT.add(pid)


def forget(pid: int) -> None:
    _KEPT.discard(pid)


def kept() -> frozenset[int]:
    return frozenset(_KEPT)


# ------------------------------------------------------------------------------ reading a pipe in time

CHUNK_BYTES = 1 << 16  # the most read_chunk returns at once


def read_chunk(fd: int, timeout: float) -> bytes:
    """The next bytes from a pipe (b"" at its end); TimeoutError when none come within `timeout`."""
    import select

    poller = select.poll()
    poller.register(fd, select.POLLIN | select.POLLHUP | select.POLLERR)
    if timeout <= 0 or not poller.poll(timeout * 1000):
        raise TimeoutError
    return os.read(fd, CHUNK_BYTES)


class StreamReader:
    """Chunks from a child's pipe within a timeout, on every system: poll where the system has it, else a
    thread that reads ahead (Windows pipes can be neither polled nor selected)."""

    def __init__(self, stream) -> None:
        import select

        self.stream = stream
        self.chunks = None
        if not hasattr(select, "poll"):
            import queue
            import threading

            self.chunks = queue.Queue()
            threading.Thread(target=self._pump, daemon=True).start()

    def _pump(self) -> None:
        while True:
            chunk = self.stream.read1(CHUNK_BYTES) if hasattr(self.stream, "read1") else self.stream.read(CHUNK_BYTES)
            self.chunks.put(chunk)
            if not chunk:
                return

    def read(self, timeout: float) -> bytes:
        """The next bytes (b"" at the pipe's end); TimeoutError when none come within `timeout`."""
        if self.chunks is None:
            return read_chunk(self.stream.fileno(), timeout)
        import queue

        try:
            return self.chunks.get(timeout=timeout) if timeout > 0 else self.chunks.get_nowait()
        except queue.Empty:
            raise TimeoutError from None


CACHE_ENVIRONMENT = "GRADER_CACHE_DIR"  # the folder for the grader's caches; empty: keep nothing


def cache_folder(kind: str) -> str | None:
    """The folder of one of the grader's caches ("figures", "results"): below GRADER_CACHE_DIR (None if it is
    empty), else below the user's cache folder of the platform, in jacobians-grader/; None where there is none."""
    given = os.environ.get(CACHE_ENVIRONMENT)
    if given is not None:
        return os.path.join(given, kind) if given.strip() else None
    home = os.path.expanduser("~")
    if home == "~":  # no home folder known
        return None
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA") or os.path.join(home, "AppData", "Local")
    elif sys.platform == "darwin":
        base = os.path.join(home, "Library", "Caches")
    else:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(home, ".cache")
    return os.path.join(base, "jacobians-grader", kind)


_TRACE_START = os.environ.get("GRADER_TRACE")  # the wall-clock time (time.time()) a benchmark started the command
_traced: list[tuple[str, float]] = []


def trace(what: str) -> None:
    """Note when `what` happened, in milliseconds since GRADER_TRACE (benchmarks/latency.py --trace); nothing
    without it."""
    if _TRACE_START:
        import time

        _traced.append((what, (time.time() - float(_TRACE_START)) * 1000))


def traced() -> list[tuple[str, float]]:
    """What trace() noted, in order."""
    return list(_traced)
