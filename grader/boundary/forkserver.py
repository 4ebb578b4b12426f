"""A fork server for batch grading: one sandboxed interpreter imports numpy once, then forks a fresh
child per grading run, so a learner costs a fork instead of a new interpreter.

A server may also preload a library learners may use (PRELOADABLE: sympy, whose import is about 0.4 s). The
grader keeps a lean server and, from the first learner whose files name such a library, one that holds it too
(grader.boundary.door); each learner is forked from the one its files call for (`preloads_for`). A fork
copies, then tears down, the pages of all that its server holds, three times per run (the fork here and the
two of grader.boundary.confine): a learner who does not use sympy is not made to pay for its pages.

The server runs inside the sandbox with no learner's files visible. For each run the parent sends,
over a Unix socket, the child's three descriptors (request pipe, result pipe, capture file); the
forked child gets the learner's files inside its request, writes them under a fresh folder and then
behaves exactly like a spawned child (grader.boundary.child.serve). When the child is done, or the parent
asks, the server kills everything the run started, removes every file it left in the sandbox's
writable folders, and only then reports the exit status: the next learner finds nothing of the last.

The server never runs learner code itself, and learner code can only hurt its own run: killing the
server ends that run as a crash, and the parent starts a new server for the next learner.
"""

from __future__ import annotations

import gc
import json
import os
import selectors
import signal
import socket
import subprocess
import sys
import time

from grader.boundary.spawn import (
    INTERPRETER,
    CommandWrapper,
    become_subreaper,
    capture_file,
    kill_orphans,
    read_capture,
)
from grader.boundary.wire import placed
from grader.system import CHUNK_BYTES, child_environment, child_path, forget, keep, read_chunk, temp_dir

_BOOT = "import sys; sys.path[:] = {!r}; from grader.boundary.forkserver import serve; serve()"
PRELOADABLE = ("sympy",)  # libraries a server may hold for the learners whose files name them
_MESSAGE = 4096
_REPLY_SECONDS = 5.0  # how long the server may take to clean up after a run before it is replaced
_PAUSE_SECONDS = 0.002  # between reads of a run's result lines (ForkedChild.read)
_RESULT_PIPE_BYTES = 1 << 20  # a run's lines wait there meanwhile, the child never blocked (Linux's unprivileged cap)


class ForkServer:
    """The parent's end: starts the server (inside `wrap`, e.g. a grader.boundary.sandbox.Sandbox) on first use
    and again whenever it has died; `start` is a grader.boundary.session Launcher."""

    def __init__(self, wrap: CommandWrapper | None = None, preload: tuple[str, ...] = ()) -> None:
        self.wrap = wrap
        self.preload = preload  # what the server imports besides numpy (some of PRELOADABLE)
        self.sandboxed = bool(getattr(wrap, "available", False))  # its own PID namespace and /tmp
        self.process: subprocess.Popen | None = None
        self.socket: socket.socket | None = None
        self._runs = 0

    def launch(self) -> None:
        """Start the server now (`start` does it on first use)."""
        parent_end, server_end = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        config = {"scratch": self.wrap.scratch_dirs() if self.sandboxed else [], "pid_namespace": self.sandboxed,
                  "preload": list(self.preload)}
        command = [sys.executable, *INTERPRETER, "-c", _BOOT.format(child_path()), str(server_end.fileno()),
                   json.dumps(config)]
        if self.wrap is not None:
            command = self.wrap(command)
        self.process = subprocess.Popen(
            command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            pass_fds=(server_end.fileno(),), start_new_session=True, env=child_environment(), cwd=temp_dir())
        keep(self.process.pid)  # the grader's own: clearing orphans (another server's close) leaves it alone
        server_end.close()
        self.socket = parent_end
        become_subreaper()

    def start(self) -> ForkedChild:
        """Fork a fresh child (a grader.boundary.session Launcher)."""
        self._runs += 1
        request_read, request_write = os.pipe()
        result_read, result_write = os.pipe()
        _widen(result_write)
        capture_fd = capture_file()
        root = f"/tmp/grade-run-{self._runs}" if self.sandboxed else \
            os.path.join(temp_dir(), f"grade-run-{os.getpid()}-{self._runs}")
        sent = False
        for _ in range(2):  # a server that died since the last run (a learner killed it) is replaced
            if self.process is None or self.process.poll() is not None:
                self.close()
                self.launch()
            try:
                socket.send_fds(self.socket, [b"run " + root.encode()], [request_read, result_write, capture_fd])
                sent = True
                break
            except OSError:
                self.close()
        for fd in (request_read, result_write):
            os.close(fd)
        return ForkedChild(self, request_write, result_read, capture_fd, root, sent)

    def reply(self, timeout: float) -> int | None:
        """The exit status the server reports for the current run; None if it gave none in time."""
        if self.socket is None:
            return None
        self.socket.settimeout(timeout)
        try:
            message = self.socket.recv(_MESSAGE)
        except (socket.timeout, OSError):
            return None
        if not message.startswith(b"exit "):
            self.close()  # the server died (EOF) or said something else: it is replaced next time
            return -signal.SIGKILL
        return int(message[5:])

    def ask_to_kill(self) -> None:
        try:
            self.socket.send(b"kill")
        except (OSError, AttributeError):
            pass

    def close(self) -> None:
        """Stop the server, its sandbox and everything in it."""
        if self.socket is not None:
            self.socket.close()
            self.socket = None
        if self.process is not None:
            forget(self.process.pid)
            try:
                os.killpg(self.process.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            self.process.wait()
            self.process = None
            kill_orphans()


def _widen(pipe_fd: int) -> None:
    """Give a pipe room for _RESULT_PIPE_BYTES (Linux: F_SETPIPE_SZ); elsewhere, or where refused, it stays as it is."""
    try:
        import fcntl

        fcntl.fcntl(pipe_fd, fcntl.F_SETPIPE_SZ, _RESULT_PIPE_BYTES)
    except (ImportError, AttributeError, OSError):  # not Linux (the constant is Linux's), or over the system's cap
        pass


class ForkedChild:
    """One forked child, driven by grader.boundary.session like a spawned one (its ChildHandle)."""

    def __init__(self, server: ForkServer, request_fd: int, read_fd: int, capture_fd: int, root: str,
                 sent: bool) -> None:
        self.server = server
        self.request_fd = request_fd
        self.read_fd = read_fd
        self.capture_fd = capture_fd
        self.root = root
        self._returncode: int | None = None if sent else -signal.SIGKILL
        self._read_before = False  # the last read returned some lines, not a full chunk

    def send(self, request: str) -> None:
        """The request, with where the child writes the submission's files."""
        try:
            with open(self.request_fd, "wb", closefd=True) as pipe:
                pipe.write(placed(request, self.root, self.server.sandboxed))
        except OSError:
            pass

    def read(self, timeout: float) -> bytes:
        """The next chunk of result lines. After a chunk, the child's next lines get a moment to gather
        (_PAUSE_SECONDS, where the deadline is further off than ten of them): the worker wakes a few dozen
        times per learner, not once for every two or three of some 850 lines. A full chunk is followed at once
        (more is waiting), and the last line is read as soon as it comes (no read follows it)."""
        if self._read_before and timeout > 10 * _PAUSE_SECONDS:
            time.sleep(_PAUSE_SECONDS)
            timeout -= _PAUSE_SECONDS
        chunk = read_chunk(self.read_fd, timeout)
        self._read_before = 0 < len(chunk) < CHUNK_BYTES
        return chunk

    def wait(self, timeout: float) -> None:
        if self._returncode is None:
            self._returncode = self.server.reply(timeout)

    @property
    def returncode(self) -> int | None:
        return self._returncode

    def stop(self, output_limit: int) -> str:
        """Have the server kill the run and clean up; replace the server if it does not answer."""
        if self._returncode is None:
            self.server.ask_to_kill()
            self._returncode = self.server.reply(_REPLY_SECONDS)
            if self._returncode is None:
                self.server.close()
                self._returncode = -signal.SIGKILL
        os.close(self.read_fd)
        return read_capture(self.capture_fd, output_limit)


# ------------------------------------------------------------------------------ the server side

def _prctl(option: int, value: int) -> None:
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(option, value, 0, 0, 0)
    except (OSError, AttributeError):
        pass


def _live_children_of(pid: int) -> list[int]:
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat", "rb") as handle:
                    fields = handle.read().rsplit(b")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid and fields[0] != b"Z":
                found.append(int(entry))
    return found


def _reap() -> None:
    while True:
        try:
            if os.waitpid(-1, os.WNOHANG)[0] == 0:
                return
        except ChildProcessError:
            return


def _kill_everything(child: int, pid_namespace: bool) -> None:
    """Kill the run's child and every process it started, and reap what has died."""
    if pid_namespace:  # alone in our own PID namespace: kill(-1) reaches every process but us and init
        for _ in range(2):
            try:
                os.kill(-1, signal.SIGKILL)
            except OSError:
                pass
    else:  # the child's session, then whatever this subreaper adopted, until none is left
        try:
            os.killpg(child, signal.SIGKILL)
        except OSError:
            pass
        me = os.getpid()
        for _ in range(1000):
            _reap()
            strays = _live_children_of(me)
            if not strays:
                break
            for pid in strays:
                try:
                    os.kill(pid, signal.SIGKILL)
                except OSError:
                    pass
            time.sleep(0.001)
    _reap()


def _wipe(folder: str, device: int | None = None) -> None:
    """Remove everything in `folder` that lies on its own file system (mount points are left alone)."""
    try:
        device = os.lstat(folder).st_dev if device is None else device
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        try:
            info = entry.stat(follow_symlinks=False)
            if info.st_dev != device:
                continue
            if entry.is_dir(follow_symlinks=False):
                os.chmod(entry.path, 0o700)
                _wipe(entry.path, device)
                os.rmdir(entry.path)
            else:
                os.unlink(entry.path)
        except OSError:
            continue


def _run_one(server: socket.socket, root: str, fds: list[int], config: dict) -> int | None:
    """Fork a child for one run, wait for it (or for the parent's kill), clean up; its exit status,
    or None when the parent has gone away."""
    from grader.boundary.child import serve as serve_request

    request_fd, result_fd, capture_fd = fds
    server_pid = os.getpid()
    try:
        os.makedirs(root, mode=0o700, exist_ok=True)
        pid = os.fork()
    except OSError:  # no room for another process or folder: this run fails, the server goes on
        for fd in fds:
            os.close(fd)
        return 71
    if pid == 0:  # the child: nothing of the server's may stay open to learner code
        try:
            server.close()
            _prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG: die with the server, never outlive it
            if os.getppid() != server_pid:
                os._exit(70)
            os.setsid()
            _prctl(4, 1)  # PR_SET_DUMPABLE: its own /proc entries stay its own
            with open(request_fd, "rb") as pipe:
                text = pipe.read().decode()
            serve_request(text, result_fd, capture_fd)
        finally:
            os._exit(70)
    for fd in fds:
        os.close(fd)
    selector = selectors.DefaultSelector()
    try:
        pidfd = os.pidfd_open(pid)
        selector.register(pidfd, selectors.EVENT_READ)
    except (AttributeError, OSError):
        pidfd = None
    selector.register(server, selectors.EVENT_READ)
    status = None
    parent_gone = False
    while status is None:
        ready = selector.select(None if pidfd is not None else 0.01)
        if any(key.fileobj is server for key, _ in ready):
            parent_gone = server.recv(_MESSAGE) == b""  # otherwise "kill"
            break
        done, wait_status = os.waitpid(pid, os.WNOHANG)
        if done:
            status = os.waitstatus_to_exitcode(wait_status)
    selector.close()
    if pidfd is not None:
        os.close(pidfd)
    _kill_everything(pid, config["pid_namespace"])
    if status is None:
        try:
            status = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
        except ChildProcessError:
            status = -signal.SIGKILL
    _wipe(root)
    try:
        os.rmdir(root)
    except OSError:
        pass
    for folder in config["scratch"]:
        _wipe(folder)
    return None if parent_gone else status


def preloads_for(files: dict[str, str]) -> tuple[str, ...]:
    """The libraries of PRELOADABLE that a submission's files (relative path -> base64, as prepared) name anywhere:
    the server to fork its learner from. A library named nowhere but imported all the same is imported by that
    learner's child, as any other."""
    import base64

    texts = [base64.b64decode(data) for data in files.values()]
    return tuple(name for name in PRELOADABLE if any(name.encode() in text for text in texts))


def _warm_up(preload: list[str]) -> None:
    """Import, once and before any fork, what every run would otherwise load again: numpy, the child
    side, the callables a request may name, numpy.random (for Generator arguments), what import
    errors and submission files need, and `preload` (libraries of PRELOADABLE the contract lets learners
    use: sympy's import, about 0.4 s, would otherwise be paid again by every learner who uses it)."""
    import base64  # noqa: F401
    import importlib
    import importlib.util  # noqa: F401
    import traceback  # noqa: F401

    import numpy as np

    for name in preload:
        if name in PRELOADABLE:
            try:
                importlib.import_module(name)
            except ImportError:
                pass

    import grader.boundary.child  # noqa: F401
    import grader.catalogue  # noqa: F401

    np.random.default_rng(0).normal(size=2)


def serve(argv: list[str] | None = None) -> None:
    """The server's loop (inside the sandbox): one run at a time until the parent closes the socket."""
    argv = sys.argv[1:] if argv is None else argv
    config = json.loads(argv[1])
    gc.disable()  # off for the imports and in each run's child until its learner code runs (child.serve)
    _warm_up(config.get("preload", []))
    gc.freeze()  # what every run's child shares: its collections never walk it (nor copy its pages)

    server = socket.socket(fileno=int(argv[0]))
    config["pid_namespace"] = config.get("pid_namespace", False) and os.getpid() <= 3
    _prctl(4, 0)  # PR_SET_DUMPABLE 0: learner processes (same uid) cannot ptrace us or read our memory
    _prctl(36, 1)  # PR_SET_CHILD_SUBREAPER: a run's orphans become ours, to be killed
    while True:
        try:
            message, fds, _, _ = socket.recv_fds(server, _MESSAGE, 3)
        except OSError:
            break
        if not message:
            break
        if not message.startswith(b"run ") or len(fds) != 3:  # e.g. a "kill" that came after the run ended
            for fd in fds:
                os.close(fd)
            continue
        status = _run_one(server, message[4:].decode(), fds, config)
        if status is None:
            break
        try:
            server.send(b"exit %d" % status)
        except OSError:
            break
    os._exit(0)
