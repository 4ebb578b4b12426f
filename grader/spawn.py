"""Start the child interpreter (grader/child.py): the first thing `grade` does, so it imports light.

Two strategies behind one call, `start_child`, chosen in one place (`strategy`) by what the system
offers, never by its name, so a test can force either:
- "posix": process groups and descriptors passed to the child (pass_fds): the result pipe and an
  unnamed capture file are the child's own descriptors; a timeout kills the process group, and on
  Linux the orphans this process adopted as a subreaper;
- "portable" (Windows, or wherever process groups are missing): the request goes to the child's
  stdin, its results come back on its stdout (the child moves learner output to a capture file it
  is given by name), and a timeout kills the process tree through a Windows job object where there is
  one, else the process.
(The batch's and the watch's fork server, grader.forkserver, is a third, where fork is safe.)
Only os, sys and subprocess here: grader.launch starts the child before the heavy imports
(click, numpy) and grader.runner adopts it.
"""

from __future__ import annotations

import os
import subprocess
import sys
from typing import Callable

GRADER_PARENT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The child runs without site (-S, faster start) on the parent's own import path, grader last.
_BOOT = "import sys; sys.path[:] = {!r}; from grader.child import main; main()"

# A hook that wraps the child's command line, e.g. in a bubblewrap sandbox (grader.sandbox.Sandbox).
CommandWrapper = Callable[[list], list]


def child_path() -> list[str]:
    """The child's sys.path: this interpreter's library folders (not the cwd), then grader's parent."""
    paths = [p for p in sys.path if p and os.path.isabs(p) and p != GRADER_PARENT]
    return [*paths, GRADER_PARENT]


def temp_dir() -> str:
    for name in ("TMPDIR", "TEMP", "TMP"):
        if os.path.isdir(os.environ.get(name, "")):
            return os.environ[name]
    if os.path.isdir("/tmp"):
        return "/tmp"
    import tempfile

    return tempfile.gettempdir()


# numpy on matrices of a few rows gains nothing from a BLAS thread pool, and OpenBLAS' idle threads
# busy-wait: in the grader they would spin beside the learner's child on the same cores.
SINGLE_THREADED_BLAS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def child_environment() -> dict:
    env = {k: os.environ[k] for k in ("PATH", "LANG", "LC_ALL", "SYSTEMROOT") if k in os.environ}
    env.update(SINGLE_THREADED_BLAS, PYTHONHASHSEED="0", PYTHONDONTWRITEBYTECODE="1")
    return env


_LIVE: set[int] = set()  # pids of the children started here and not yet stopped
_SUBREAPER = False


def become_subreaper() -> None:
    """Linux: adopt orphaned descendants (a learner's `setsid` grandchildren, which leave the
    process group) so that kill_orphans() can find them. Elsewhere a no-op."""
    global _SUBREAPER
    if _SUBREAPER:
        return
    try:
        import ctypes

        _SUBREAPER = ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0) == 0  # PR_SET_CHILD_SUBREAPER
    except (OSError, AttributeError, TypeError):  # no prctl here (not Linux)
        pass


def own(pid: int) -> None:
    """A process of the grader's own (the HTML report's drawing process), never learner code: kill_orphans
    leaves it alone, as it does the children started here, until forget(pid)."""
    _LIVE.add(pid)


def kill_orphans() -> None:
    """Kill and reap the adopted processes that are not one of our live children."""
    if not _SUBREAPER:
        return
    me = os.getpid()
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) in _LIVE:
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as handle:
                fields = handle.read().rsplit(b")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == me:
            pid = int(entry)
            try:
                os.kill(pid, 9)
                os.waitpid(pid, os.WNOHANG)
            except (ProcessLookupError, ChildProcessError, PermissionError):
                pass


def forget(pid: int) -> None:
    _LIVE.discard(pid)


def capture_file() -> int:
    """An unnamed temporary file for learner stdout/stderr, outside any sandbox: its descriptor."""
    if hasattr(os, "O_TMPFILE"):
        try:
            return os.open(temp_dir(), os.O_TMPFILE | os.O_RDWR, 0o600)
        except OSError:  # a file system without O_TMPFILE
            pass
    import tempfile

    return os.dup(tempfile.TemporaryFile(dir=temp_dir()).fileno())  # the dup outlives the file object


def read_capture(fd: int, limit: int) -> str:
    """Up to `limit` bytes of what learner code printed; closes the descriptor."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return os.read(fd, limit).decode("utf-8", "replace")
    except OSError:
        return ""
    finally:
        os.close(fd)


def read_chunk(fd: int, timeout: float) -> bytes:
    """The next bytes from a pipe (b"" at its end); TimeoutError when none come within `timeout`."""
    import select

    poller = select.poll()
    poller.register(fd, select.POLLIN | select.POLLHUP | select.POLLERR)
    if timeout <= 0 or not poller.poll(timeout * 1000):
        raise TimeoutError
    return os.read(fd, 1 << 16)


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
            chunk = self.stream.read1(1 << 16) if hasattr(self.stream, "read1") else self.stream.read(1 << 16)
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


def start_helper(command: list[str]) -> subprocess.Popen:
    """A helper interpreter of the grader's own (e.g. sympy's worker) talking over stdin and stdout, in a
    process group of its own where the system has them, so that stop_helper ends all it started."""
    posix = strategy() == "posix"
    return subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            bufsize=0, env=child_environment(), start_new_session=posix,
                            creationflags=0 if posix else getattr(subprocess, "CREATE_NEW_PROCESS_GROUP", 0))


def stop_helper(process: subprocess.Popen) -> None:
    """Kill a start_helper process (with its process group where there is one) and close its pipes."""
    try:
        if strategy() == "posix":
            os.killpg(process.pid, 9)
        else:
            process.kill()
    except (ProcessLookupError, PermissionError, OSError):
        pass
    process.wait()
    for stream in (process.stdin, process.stdout):
        try:
            stream.close()
        except OSError:
            pass


def strategy() -> str:
    """How children start here: "posix" where process groups and passed descriptors exist, else
    "portable"; GRADER_LAUNCHER forces one (for tests of the other)."""
    forced = os.environ.get("GRADER_LAUNCHER", "")
    if forced in ("posix", "portable"):
        return forced
    return "posix" if hasattr(os, "killpg") and hasattr(os, "setsid") and hasattr(os, "fork") else "portable"


def fork_is_safe() -> bool:
    """Whether a process that has loaded numpy may fork here (grader.forkserver, the HTML report's
    drawing): fork and descriptors over Unix sockets exist and multiprocessing does not default to
    "spawn" (macOS does: fork after its system libraries is unsafe there); not where GRADER_LAUNCHER
    forces the portable strategy (Windows' route)."""
    if os.environ.get("GRADER_LAUNCHER") == "portable":
        return False
    import multiprocessing
    import socket

    return (hasattr(os, "fork") and hasattr(socket, "send_fds") and hasattr(socket, "AF_UNIX")
            and multiprocessing.get_start_method(allow_none=False) != "spawn")


def _scratch(sandboxed: bool) -> tuple[str, str]:
    """(a folder for the child's work, where it writes the learner's files): in the sandbox's own /tmp,
    else a fresh private folder on the host (removed when the child stops)."""
    if sandboxed:
        return "/tmp", "/tmp/submission"
    import tempfile

    scratch = tempfile.mkdtemp(prefix="grade-", dir=temp_dir())
    return scratch, os.path.join(scratch, "submission")


def _send(stream, request: dict) -> None:
    import json

    try:
        stream.write(json.dumps(request).encode("utf-8"))
        stream.close()
    except (BrokenPipeError, OSError):
        pass


class _Started:
    """What both kinds of child share: the started process's wait and exit status."""

    process: subprocess.Popen

    def wait(self, timeout: float) -> None:
        try:
            self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            pass

    @property
    def returncode(self) -> int | None:
        """The exit status (negative: killed by that signal), or None while it runs."""
        return self.process.poll()


class SpawnedChild(_Started):
    """A child interpreter started by start_child: its process (group), result pipe, output file, and
    the folder it writes the learner's files to (`root`; removed at stop when it is on the host)."""

    def __init__(self, process: subprocess.Popen, read_fd: int, capture_fd: int, root: str,
                 host_root: bool) -> None:
        self.process = process
        self.read_fd = read_fd
        self.capture_fd = capture_fd
        self.root = root
        self.host_root = host_root

    def send(self, request: dict) -> None:
        """Write the whole request (with where to put the learner's files) to the child's stdin and close it."""
        _send(self.process.stdin, dict(request, root=self.root, confine=not self.host_root))

    def read(self, timeout: float) -> bytes:
        return read_chunk(self.read_fd, timeout)

    def stop(self, output_limit: int) -> str:
        """Kill the whole process group and stray grandchildren; return what learner code printed."""
        try:
            os.killpg(self.process.pid, 9)
        except (ProcessLookupError, PermissionError):
            pass
        self.process.wait()
        forget(self.process.pid)
        kill_orphans()  # grandchildren that left the process group with setsid
        os.close(self.read_fd)
        if self.host_root:
            import shutil

            shutil.rmtree(os.path.dirname(self.root), ignore_errors=True)
        return read_capture(self.capture_fd, output_limit)


class PortableChild(_Started):
    """A child started without process groups or passed descriptors (strategy "portable"): request on
    its stdin, results on its stdout (read by a thread: Windows pipes cannot be selected), learner
    output in a capture file it was given by name, its process tree in a Windows job object if any."""

    def __init__(self, process: subprocess.Popen, capture: str, scratch: str, root: str, job: object) -> None:
        self.process = process
        self.capture = capture
        self.scratch = scratch
        self.root = root
        self.job = job
        self.results = StreamReader(process.stdout)

    def send(self, request: dict) -> None:
        _send(self.process.stdin, dict(request, root=self.root, confine=False))

    def read(self, timeout: float) -> bytes:
        return self.results.read(timeout)

    def stop(self, output_limit: int) -> str:
        """Kill the child's process tree; return what learner code printed."""
        if not _end_job(self.job):
            try:
                self.process.kill()
            except OSError:
                pass
        self.process.wait()
        for stream in (self.process.stdout, self.process.stdin):
            try:
                stream.close()
            except OSError:
                pass
        try:
            with open(self.capture, "rb") as handle:
                printed = handle.read(output_limit).decode("utf-8", "replace")
        except OSError:
            printed = ""
        import shutil

        shutil.rmtree(self.scratch, ignore_errors=True)
        return printed


def _job_for(process: subprocess.Popen, memory_bytes: int | None) -> object:
    """Windows: a job object holding the child (and all it starts), killed as a whole, its memory capped;
    None elsewhere (or if the system refuses)."""
    try:
        import ctypes
        from ctypes import wintypes

        kernel32 = ctypes.WinDLL("kernel32", use_last_error=True)
    except (ImportError, AttributeError, OSError):
        return None

    class Limits(ctypes.Structure):
        _fields_ = [("PerProcessUserTimeLimit", ctypes.c_int64), ("PerJobUserTimeLimit", ctypes.c_int64),
                    ("LimitFlags", wintypes.DWORD), ("MinimumWorkingSetSize", ctypes.c_size_t),
                    ("MaximumWorkingSetSize", ctypes.c_size_t), ("ActiveProcessLimit", wintypes.DWORD),
                    ("Affinity", ctypes.c_size_t), ("PriorityClass", wintypes.DWORD),
                    ("SchedulingClass", wintypes.DWORD)]

    class Counters(ctypes.Structure):
        _fields_ = [(name, ctypes.c_uint64) for name in ("r", "w", "o", "rb", "wb", "ob")]

    class Extended(ctypes.Structure):
        _fields_ = [("Basic", Limits), ("Io", Counters), ("ProcessMemoryLimit", ctypes.c_size_t),
                    ("JobMemoryLimit", ctypes.c_size_t), ("PeakProcessMemoryUsed", ctypes.c_size_t),
                    ("PeakJobMemoryUsed", ctypes.c_size_t)]

    job = kernel32.CreateJobObjectW(None, None)
    if not job:
        return None
    info = Extended()
    info.Basic.LimitFlags = 0x2000 | (0x200 if memory_bytes else 0)  # KILL_ON_JOB_CLOSE, JOB_MEMORY
    info.JobMemoryLimit = memory_bytes or 0
    kernel32.SetInformationJobObject(job, 9, ctypes.byref(info), ctypes.sizeof(info))  # extended limits
    if not kernel32.AssignProcessToJobObject(job, int(process._handle)):
        kernel32.CloseHandle(job)
        return None
    return (kernel32, job)


def _end_job(job: object) -> bool:
    if job is None:
        return False
    kernel32, handle = job
    done = bool(kernel32.TerminateJobObject(handle, 1))
    kernel32.CloseHandle(handle)
    return done


def start_child(submission, wrap: CommandWrapper | None = None, memory_bytes: int | None = 1 << 30):
    """Start a fresh child interpreter for `submission` (the strategy this system offers), wrapped
    (e.g. sandboxed) by `wrap`; the submission's files reach it in the request (grader.wire),
    written under a folder of its own."""
    if strategy() == "portable":  # no bubblewrap where this runs (Windows): the child on the host
        scratch, root = _scratch(False)
        capture = os.path.join(scratch, "printed.txt")
        command = [sys.executable, "-I", "-S", "-c", _BOOT.format(child_path()), "--portable", capture]
        process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                   env=child_environment(), cwd=scratch,
                                   creationflags=getattr(subprocess, "CREATE_NEW_PROCESS_GROUP", 0))
        return PortableChild(process, capture, scratch, root, _job_for(process, memory_bytes))
    sandboxed = bool(getattr(wrap, "available", False))  # then the child has a /tmp of its own
    scratch, root = _scratch(sandboxed)
    read_fd, write_fd = os.pipe()
    capture_fd = capture_file()
    command = [sys.executable, "-I", "-S", "-c", _BOOT.format(child_path()), str(write_fd), str(capture_fd)]
    if wrap is not None:
        command = wrap(command)
    process = subprocess.Popen(
        command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        pass_fds=(write_fd, capture_fd), start_new_session=True, env=child_environment(),
        cwd=temp_dir() if sandboxed else scratch,
    )
    os.close(write_fd)
    _LIVE.add(process.pid)
    become_subreaper()  # after the start: the child imports numpy long before learner code runs
    return SpawnedChild(process, read_fd, capture_fd, root, host_root=not sandboxed)
