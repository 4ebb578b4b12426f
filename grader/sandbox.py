"""Hardened isolation for learner code: the child runs inside bubblewrap when it is installed.

Inside: no network, read-only root, a fresh /tmp, its own PID namespace (the sandbox's processes
all die with it), a new session; the reference solutions, quiz keys, the project's own exercises,
the submissions folder and the output folder are hidden (empty tmpfs over them), and only this
learner's staged files are bound back, read-only. Run as root, learner code drops to uid/gid
65534 (nobody) with no capabilities. Without bubblewrap it falls back to the resource limits and
process-group kill of grader.runner alone, and says so in one line.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

from grader.spawn import GRADER_PARENT, child_path
from grader.submission import Submission

NOBODY = 65534


def _hidden_defaults() -> list[str]:
    """Folders learner code must not see: references, keys, the project's exercises."""
    paths = [os.path.join(GRADER_PARENT, name) for name in ("solutions", "quizzes", "exercises", ".git")]
    try:
        import importlib.util

        spec = importlib.util.find_spec("solutions")
        if spec and spec.submodule_search_locations:
            paths.extend(spec.submodule_search_locations)
    except (ImportError, ValueError):
        pass
    return [p for p in dict.fromkeys(paths) if os.path.isdir(p)]


class Sandbox:
    """A grader.runner CommandWrapper: `Session(submission, wrap=Sandbox(...))`."""

    def __init__(self, hide: list[str | Path] = ()) -> None:
        self.bwrap = None if os.environ.get("GRADER_SANDBOX") == "off" else shutil.which("bwrap")
        self.setpriv = shutil.which("setpriv")
        self.hide = [str(Path(p).resolve()) for p in hide] + _hidden_defaults()
        self.drops_to_nobody = os.geteuid() == 0 and self.setpriv is not None
        # Root's home, usually 0700, becomes an empty tmpfs when learner code runs as nobody.
        home = os.path.expanduser("~")
        self.emptied_home = home if self.drops_to_nobody and home not in ("/", "") and os.path.isdir(home) else None

    @property
    def available(self) -> bool:
        return self.bwrap is not None

    def describe(self) -> str:
        if not self.available:
            return ("isolation: bubblewrap (bwrap) not found; learner code runs with resource limits and a "
                    "process-group kill only (apt-get install bubblewrap for the sandbox)")
        who = "as uid 65534" if self.drops_to_nobody else "as the current user"
        return f"isolation: bubblewrap sandbox (no network, read-only root, fresh /tmp, others' files hidden), {who}"

    def scratch_dirs(self) -> list[str]:
        """The only folders learner code can write to inside the sandbox (each a fresh tmpfs)."""
        return ["/tmp", "/dev/shm"] + ([self.emptied_home] if self.emptied_home else [])

    def __call__(self, command: list[str], submission: Submission | None) -> list[str]:
        """`command` inside the sandbox, seeing `submission`'s files read-only (None: no learner's files)."""
        if not self.available:
            return command
        args = [self.bwrap, "--ro-bind", "/", "/", "--dev", "/dev", "--proc", "/proc", "--perms", "01777", "--tmpfs", "/tmp"]
        emptied = ["/tmp"]  # folders replaced by an empty tmpfs: bind targets inside need their parents made
        if self.emptied_home:
            args += ["--tmpfs", self.emptied_home]
            emptied.append(self.emptied_home)
        # The interpreter, its libraries and the grader package must stay visible even where they
        # live inside an emptied folder (a virtual environment in /tmp, pyenv in root's home).
        needed = {sys.prefix, sys.base_prefix, os.path.dirname(os.path.realpath(sys.executable)),
                  *(p for p in child_path() if p != GRADER_PARENT), os.path.join(GRADER_PARENT, "grader")}
        inside = sorted(p for p in needed if os.path.exists(p) and any(p.startswith(e + os.sep) for e in emptied))
        for path in _outermost(inside):
            args += _parents(path, emptied) + ["--ro-bind", path, path]
        hidden = []
        for path in self.hide:
            if any(path == e or path.startswith(e + os.sep) for e in emptied):
                continue  # already inside an empty tmpfs
            args += _parents(path, emptied) + ["--tmpfs", path]
            hidden.append(path)
        chdir = "/tmp"
        if submission is not None:
            root = chdir = str(Path(submission.root).resolve())
            args += _parents(root, emptied + hidden) + ["--ro-bind", root, root]
            hidden = [p for p in hidden if not p.startswith(root + os.sep)]  # no longer a mount point
        for path in hidden:  # nothing may be left there for the next learner of a fork server
            args += ["--remount-ro", path]
        args += ["--unshare-ipc", "--unshare-pid", "--unshare-net", "--unshare-uts", "--unshare-cgroup-try",
                 "--die-with-parent", "--new-session", "--chdir", chdir, "--"]
        if self.drops_to_nobody:
            args += [self.setpriv, f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups",
                     "--inh-caps=-all", "--bounding-set=-all"]
        return args + command


def _parents(path: str, emptied: list[str]) -> list[str]:
    """bwrap arguments making the folders above `path` inside an emptied folder, traversable (0755)."""
    args = []
    for top in emptied:
        if path.startswith(top + os.sep):
            relative = Path(path).relative_to(top).parts[:-1]
            current = top
            for part in relative:
                current = os.path.join(current, part)
                args += ["--perms", "0755", "--dir", current]
    return args


def _outermost(paths: list[str]) -> list[str]:
    """Drop paths that lie inside another path of the list."""
    out: list[str] = []
    for path in sorted(paths, key=len):
        if not any(path == p or path.startswith(p + os.sep) for p in out):
            out.append(path)
    return out


def learner_sandbox() -> Sandbox | None:
    """The sandbox for `grade chNN`, or None where bubblewrap is not installed (or GRADER_SANDBOX=off)."""
    sandbox = Sandbox()
    return sandbox if sandbox.available else None
