"""Start the child interpreter (grader/child.py): the first thing `grade` does, so it imports light.

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
    return "/tmp"


def child_environment() -> dict:
    env = {k: os.environ[k] for k in ("PATH", "LANG", "LC_ALL", "SYSTEMROOT") if k in os.environ}
    env.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1",
               PYTHONHASHSEED="0", PYTHONDONTWRITEBYTECODE="1")
    return env


_LIVE: set[int] = set()  # pids of the children started here and not yet stopped
_SUBREAPER = False


def become_subreaper() -> None:
    """Linux: adopt orphaned descendants (a learner's `setsid` grandchildren, which leave the
    process group) so that kill_orphans() can find them. Elsewhere a no-op."""
    global _SUBREAPER
    if _SUBREAPER or not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)  # PR_SET_CHILD_SUBREAPER
        _SUBREAPER = True
    except (OSError, AttributeError):
        pass


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
        return os.pread(fd, limit, 0).decode("utf-8", "replace")
    except OSError:
        return ""
    finally:
        os.close(fd)


class SpawnedChild:
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
        import json

        request = dict(request, root=self.root, confine=not self.host_root)
        try:
            self.process.stdin.write(json.dumps(request).encode())
            self.process.stdin.close()
        except (BrokenPipeError, OSError):
            pass

    def wait(self, timeout: float) -> None:
        try:
            self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            pass

    @property
    def returncode(self) -> int | None:
        """The exit status (negative: killed by that signal), or None while it runs."""
        return self.process.poll()

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


def start_child(submission, wrap: CommandWrapper | None = None) -> SpawnedChild:
    """Start a fresh child interpreter for `submission`, wrapped (e.g. sandboxed) by `wrap`; the
    submission's files reach it in the request (grader.wire), written under a folder of its own."""
    read_fd, write_fd = os.pipe()
    capture_fd = capture_file()
    command = [sys.executable, "-I", "-S", "-c", _BOOT.format(child_path()), str(write_fd), str(capture_fd)]
    sandboxed = bool(getattr(wrap, "available", False))  # then the child has a /tmp of its own
    if sandboxed:
        scratch, root = "/tmp", "/tmp/submission"
    else:
        import tempfile

        scratch = tempfile.mkdtemp(prefix="grade-", dir=temp_dir())
        root = os.path.join(scratch, "submission")
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
