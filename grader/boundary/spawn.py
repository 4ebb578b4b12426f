"""Start the learner's child interpreter (grader.boundary.child) fresh: one per session.

Two kinds behind one call, `start_child`; grader.boundary.door.choose says which this system gets:
- posix (portable=False): process groups and descriptors passed to the child (pass_fds): the result pipe
  and an unnamed capture file are the child's own descriptors; a timeout kills the process group, and on
  Linux the orphans this process adopted as a subreaper;
- portable (Windows, or wherever process groups are missing): the request goes to the child's stdin, its
  results come back on its stdout (the child moves learner output to a capture file it is given by name),
  and a timeout kills the process tree through a Windows job object where there is one, else the process.
(grader.boundary.forkserver is the third: a resident interpreter that forks a child per session.)
Only os and sys at import (subprocess where a child needs it): grader.faces.launch starts the child before the heavy
imports (click, numpy); a sandboxed child is started with os.posix_spawn where the system has it, without
subprocess (its import alone is 9 ms of the launcher's path).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable

from grader.system import (
    StreamReader,
    child_environment,
    child_path,
    forget,
    keep,
    kept,
    read_chunk,
    temp_dir,
)

# The child's command line: the interpreter isolated (-I), without site (-S, faster), in UTF-8 mode (-X utf8: a
# learner printing σ on Windows would otherwise fail there, in the console's code page, and pass elsewhere), on
# the grader's own path. The collector stays off until learner code runs (grader.boundary.child.serve).
INTERPRETER = ("-I", "-S", "-X", "utf8")
_BOOT = "import gc; gc.disable(); import sys; sys.path[:] = {!r}; from grader.boundary.child import main; main()"

TYPE_CHECKING = False  # not typing's: its import costs the launcher 5 ms before the child starts
if TYPE_CHECKING:
    import subprocess

# A hook that wraps the child's command line, e.g. in a bubblewrap sandbox (grader.boundary.sandbox.Sandbox).
CommandWrapper = Callable[[list], list]

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


def kill_orphans() -> None:
    """Kill and reap the adopted processes that are not one of the grader's own (grader.system.keep)."""
    if not _SUBREAPER:
        return
    spared = set(kept())
    for _ in range(3):  # the kernel's lists can miss a living child while others exit: read again after killing
        found = [pid for pid in _children() if pid not in spared]
        if not _kill(found):
            return
        spared.update(found)  # killed (and reaped where they ended at once): not sought again
    _kill([pid for pid in _children(scan=True) if pid not in spared])  # still more: every process's parent


def _kill(pids: list[int]) -> bool:
    """Kill and reap (where they ended at once) the processes `pids`; whether there were any."""
    for pid in pids:
        try:
            os.kill(pid, 9)
            os.waitpid(pid, os.WNOHANG)
        except (ProcessLookupError, ChildProcessError, PermissionError):
            pass
    return bool(pids)


def _children(scan: bool = False) -> list[int]:
    """This process's children (adopted orphans among them): from each thread's /proc children list where the
    kernel keeps one, else (or with `scan`) from every process's parent in /proc."""
    me = os.getpid()
    if not scan:
        try:
            found: list[int] = []
            for thread in os.listdir(f"/proc/{me}/task"):
                with open(f"/proc/{me}/task/{thread}/children", "rb") as handle:
                    found += map(int, handle.read().split())
            return found
        except (OSError, ValueError):  # a kernel without CONFIG_PROC_CHILDREN
            pass
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as handle:
                if int(handle.read().rsplit(b")", 1)[1].split()[1]) == me:
                    found.append(int(entry))
        except (OSError, ValueError, IndexError):
            continue
    return found


def capture_file() -> int:
    """An unnamed temporary file for learner stdout/stderr, outside any sandbox: its descriptor."""
    if hasattr(os, "O_TMPFILE"):
        try:
            return os.open(temp_dir(), os.O_TMPFILE | os.O_RDWR, 0o600)
        except OSError:  # a file system without O_TMPFILE
            pass
    import tempfile

    with tempfile.TemporaryFile(dir=temp_dir()) as handle:  # open until the dup exists, which outlives it
        return os.dup(handle.fileno())


def read_capture(fd: int, limit: int) -> str:
    """Up to `limit` bytes of what learner code printed; closes the descriptor."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return os.read(fd, limit).decode("utf-8", "replace")
    except OSError:
        return ""
    finally:
        os.close(fd)


def _scratch(sandboxed: bool) -> tuple[str, str]:
    """(a folder for the child's work, where it writes the learner's files): in the sandbox's own /tmp,
    else a fresh private folder on the host (removed when the child stops)."""
    if sandboxed:
        return "/tmp", "/tmp/submission"
    import tempfile

    scratch = tempfile.mkdtemp(prefix="grade-", dir=temp_dir())
    return scratch, os.path.join(scratch, "submission")


def _send(stream, request: bytes) -> None:
    """Write the request and close the pipe; a child already gone (a broken pipe) gets it closed all the same."""
    try:
        stream.write(request)
    except OSError:  # BrokenPipeError among them
        pass
    try:
        stream.close()  # its flush fails again where the write did; the descriptor is closed even so
    except OSError:
        pass


class _Started:
    """What both kinds of child share: the started process's wait and exit status."""

    process: subprocess.Popen | _Spawned

    def wait(self, timeout: float) -> None:
        if isinstance(self.process, _Spawned):
            self.process.wait(timeout)
            return
        import subprocess

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
    the folder it writes the learner's files to (`root`; removed at stop when it is on the host); `barrier`: one of a
    uid of learner code's own (grader.boundary.dropped.DroppedUser), which watched its memory and kills every process
    of that uid once it is stopped."""

    def __init__(self, process: subprocess.Popen | _Spawned, read_fd: int, capture_fd: int, root: str,
                 host_root: bool, barrier=None) -> None:
        self.process = process
        self.read_fd = read_fd
        self.capture_fd = capture_fd
        self.root = root
        self.host_root = host_root
        self.barrier = barrier

    @property
    def returncode(self) -> int | None:
        """The exit status (negative: killed by that signal), or None while it runs; OUT_OF_MEMORY where its barrier
        killed it for the memory of all its processes together."""
        code = self.process.poll()
        watch = getattr(self.barrier, "watch", None)  # during the run; its verdict stays once the run is over
        if code is not None and (getattr(watch, "exceeded", False) or getattr(self.barrier, "out_of_memory", False)):
            from grader.boundary.confine import OUT_OF_MEMORY

            return OUT_OF_MEMORY
        return code

    def send(self, request: str) -> None:
        """Write the whole request (with where to put the learner's files) to the child's stdin and close it."""
        # loaded by then (grader.boundary.session), and kept off the launcher's path
        from grader.boundary.wire import placed

        become_subreaper()  # before learner code can start a process that leaves the group (not before: ctypes)
        _send(self.process.stdin, placed(request, self.root, not self.host_root))

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
        if self.barrier is not None:
            self.barrier.after_run()
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

    def send(self, request: str) -> None:
        from grader.boundary.wire import placed

        _send(self.process.stdin, placed(request, self.root, False))

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


class _Spawned:
    """A sandboxed child started with os.posix_spawn: what SpawnedChild uses of a subprocess.Popen (pid, stdin,
    poll, wait), without importing subprocess."""

    def __init__(self, pid: int, stdin) -> None:
        self.pid = pid
        self.stdin = stdin
        self.returncode: int | None = None

    def poll(self) -> int | None:
        """The exit status (negative: killed by that signal), or None while it runs."""
        if self.returncode is None:
            try:
                pid, status = os.waitpid(self.pid, os.WNOHANG)
            except ChildProcessError:  # reaped already (grader.boundary.spawn.kill_orphans)
                self.returncode = 0
                return self.returncode
            if pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int | None:
        """Wait for the exit (at most `timeout` seconds; None: however long it takes); its status, or None."""
        if timeout is None:
            while self.returncode is None:
                try:
                    self.returncode = os.waitstatus_to_exitcode(os.waitpid(self.pid, 0)[1])
                except ChildProcessError:
                    self.returncode = 0
            return self.returncode
        import time

        end, pause = time.monotonic() + timeout, 0.0005
        while self.poll() is None and time.monotonic() < end:
            time.sleep(min(pause, max(0.0, end - time.monotonic())))
            pause = min(pause * 2, 0.05)
        return self.returncode


def _posix_spawn(command: list[str], read_fd: int, write_fd: int, capture_fd: int):
    """Start `command` (its last two arguments the child's ends of the result pipe and capture file, to be
    numbered here) in a session of its own, with a pipe for the request on its stdin and stdout and stderr on
    /dev/null; (a _Spawned, the request pipe's read end, to close) or None where os.posix_spawn cannot (then
    subprocess does). The child's descriptors are duplicated to numbers above every one named here, so no other
    descriptor of this process reaches it."""
    spawn = getattr(os, "posix_spawn", None)
    if spawn is None or not os.path.isabs(command[0]):
        return None
    import signal

    request_read, request_write = os.pipe()
    high = max(request_read, request_write, read_fd, write_fd, capture_fd) + 1
    actions = [(os.POSIX_SPAWN_DUP2, request_read, 0), (os.POSIX_SPAWN_OPEN, 1, os.devnull, os.O_WRONLY, 0),
               (os.POSIX_SPAWN_DUP2, 1, 2), (os.POSIX_SPAWN_DUP2, write_fd, high),
               (os.POSIX_SPAWN_DUP2, capture_fd, high + 1)]
    command = [*command[:-2], str(high), str(high + 1)]
    try:
        pid = spawn(command[0], command, child_environment(), file_actions=actions, setsid=True,
                    setsigdef=(signal.SIGPIPE, signal.SIGXFSZ))
    except (NotImplementedError, OSError):  # no setsid for posix_spawn here
        os.close(request_read)
        os.close(request_write)
        return None
    os.close(request_read)
    return _Spawned(pid, os.fdopen(request_write, "wb"))


def start_child(wrap: CommandWrapper | None = None, portable: bool = False, memory_bytes: int | None = 1 << 30):
    """Start a fresh child interpreter, wrapped (e.g. sandboxed) by `wrap`; `portable`: without process groups
    or passed descriptors (Windows). The submission's files reach it in the request (grader.boundary.wire),
    written under a folder of its own."""
    if portable:  # no bubblewrap where this runs (Windows): the child on the host
        import subprocess

        scratch, root = _scratch(False)
        capture = os.path.join(scratch, "printed.txt")
        command = [sys.executable, *INTERPRETER, "-c", _BOOT.format(child_path()), "--portable", capture]
        process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                   env=child_environment(), cwd=scratch,
                                   creationflags=getattr(subprocess, "CREATE_NEW_PROCESS_GROUP", 0))
        return PortableChild(process, capture, scratch, root, _job_for(process, memory_bytes))
    sandboxed = bool(getattr(wrap, "available", False))  # then the child has a /tmp of its own
    if hasattr(wrap, "before_run"):  # a barrier of its own uid: nothing of an earlier run left, its memory watched
        wrap.before_run(memory_bytes)
    scratch, root = _scratch(sandboxed)
    if not sandboxed and hasattr(wrap, "give"):  # a child under another uid writes into its host folder
        wrap.give(scratch)
    read_fd, write_fd = os.pipe()
    capture_fd = capture_file()
    command = [sys.executable, *INTERPRETER, "-c", _BOOT.format(child_path()), str(write_fd), str(capture_fd)]
    if wrap is not None:
        command = wrap(command)
    # a sandboxed child has its own working folder (bubblewrap's --chdir): os.posix_spawn, which sets none, serves
    process = _posix_spawn(command, read_fd, write_fd, capture_fd) if sandboxed else None
    if process is None:
        import subprocess

        process = subprocess.Popen(
            command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            pass_fds=(write_fd, capture_fd), start_new_session=True, env=child_environment(),
            cwd=temp_dir() if sandboxed else scratch,
        )
    os.close(write_fd)
    keep(process.pid)
    return SpawnedChild(process, read_fd, capture_fd, root, host_root=not sandboxed,
                        barrier=wrap if hasattr(wrap, "after_run") else None)
