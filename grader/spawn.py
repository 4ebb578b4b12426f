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
_capture_count = 0

# A hook that wraps the child's command line, e.g. in a bubblewrap sandbox: (command, submission).
CommandWrapper = Callable[[list, object], list]


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


def _become_subreaper() -> None:
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


def start_child(submission, wrap: CommandWrapper | None = None) -> tuple[subprocess.Popen, int, str]:
    """Start a child for `submission`: (process, read end of its result pipe, capture file path)."""
    global _capture_count
    _capture_count += 1
    read_fd, write_fd = os.pipe()
    folder = getattr(wrap, "capture_dir", None) or temp_dir()  # a sandbox shares only its capture dir
    capture = os.path.join(folder, f"grade-output-{os.getpid()}-{_capture_count}.txt")
    command = [sys.executable, "-I", "-S", "-c", _BOOT.format(child_path()), str(write_fd)]
    if wrap is not None:
        command = wrap(command, submission)
    process = subprocess.Popen(
        command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        pass_fds=(write_fd,), start_new_session=True, env=child_environment(),
        cwd=str(submission.root),
    )
    os.close(write_fd)
    _LIVE.add(process.pid)
    _become_subreaper()  # after the start: the child imports numpy long before learner code runs
    return process, read_fd, capture
