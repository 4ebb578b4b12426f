"""The door's last decision for a one-off `grade`, kept between commands: the sandbox's command line, built once.

grader.boundary.door.choose decides how learner code runs, and grader.boundary.sandbox builds bubblewrap's
allow-list from what is installed (the interpreter, its standard library, numpy, sympy, an autograd library
with what it requires, the child's own modules): some 50 read-only binds, found by asking the import system
and reading package metadata. That is the same command after command, so the one-off `grade` keeps the
decision, with the allow-list, in the user's cache folder; the next command's launcher (grader.faces.launch) reads it
with os alone and starts the child before anything else is imported.

A kept decision holds only while what made it holds: the mode asked, the environment the door reads (the
grader's own settings, GRADER_*, and PATH), the user, the interpreter and the path a child gets, and the
modification times of every folder the allow-list was read from (an install or removal changes them) and of
bubblewrap itself. Anything else is a miss, and the door decides afresh. It is read and written by the one-off
command only (`remember`), never by batch, Gradescope or a resident boundary; like the grader's own files, it
is as safe as this user's cache folder (learner code can write it only where it ever ran unsandboxed as this
user, when it could as well have rewritten the grader).
"""

from __future__ import annotations

import os
import sys

from grader.system import cache_folder, child_path

_NOT_READ_BY_THE_DOOR = ("GRADER_TRACE", "GRADER_CACHE_DIR", "GRADER_WARM_JUDGE")


def _file() -> str | None:
    folder = cache_folder("launch")
    return None if folder is None else os.path.join(folder, "decision")


def _condition(mode: str) -> str:
    """What the decision depends on besides the watched paths, as text."""
    euid = os.geteuid() if hasattr(os, "geteuid") else None
    settings = sorted((k, v) for k, v in os.environ.items() if k.startswith("GRADER_") and k not in _NOT_READ_BY_THE_DOOR)
    return repr([mode, settings, os.environ.get("PATH"), euid, sys.executable, sys.version, child_path()])


def _stamp(path: str) -> str:
    try:
        return str(os.stat(path).st_mtime_ns)
    except OSError:
        return "missing"


# The file: fields separated by NUL, which no path or argument holds (read without json: 4 ms of the launcher's
# path): the condition, the number of watched paths, each watched path and its stamp, then the command prefix.

def wrapper(mode: str) -> list[str] | None:
    """The kept command prefix (bubblewrap, its arguments, the drop of privileges) for sandbox mode `mode`, if
    the decision still holds here; else None."""
    path = _file()
    if path is None:
        return None
    try:
        with open(path, encoding="utf-8") as handle:
            fields = handle.read().split("\0")
        watched = int(fields[1])
    except (OSError, ValueError, IndexError):
        return None
    if fields[0] != _condition(mode) or watched < 0 or len(fields) <= 2 + 2 * watched:
        return None
    for i in range(2, 2 + 2 * watched, 2):
        if _stamp(fields[i]) != fields[i + 1]:
            return None
    return fields[2 + 2 * watched:]


def keep(mode: str, prefix: list[str], watched: list[str], tree: str | None = None) -> None:
    """Keep the door's decision for `mode`: the command prefix, the paths whose change undoes it and the prepared
    tree it binds (the trees of earlier decisions are removed). Failing to write is not an error."""
    path = _file()
    if path is None or any("\0" in text for text in [*prefix, *watched]):
        return
    fields = [_condition(mode), str(len(watched)), *(x for p in watched for x in (p, _stamp(p))), *prefix]
    temporary = f"{path}.{os.getpid()}.tmp"
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(temporary, "w", encoding="utf-8") as handle:
            handle.write("\0".join(fields))
        os.replace(temporary, path)
    except (OSError, ValueError):
        try:
            os.unlink(temporary)
        except OSError:
            pass
        return
    import shutil

    folder = os.path.dirname(path)
    for name in os.listdir(folder):
        if name.startswith("tree-") and os.path.join(folder, name) != tree:
            shutil.rmtree(os.path.join(folder, name), ignore_errors=True)


def forget() -> None:
    """Drop the kept decision (a child it started did not start): the next command's door decides afresh."""
    path = _file()
    if path is not None:
        try:
            os.unlink(path)
        except OSError:
            pass


def prepare_tree(child_modules: tuple[str, ...], grader_dir: str, system_files: tuple[str, ...]) -> str | None:
    """A fresh folder in the cache holding copies of the child's grader modules (grader/..., their times kept, so
    their compiled files stay valid) and of the system's files (etc/...), for the sandbox to bind as two folders;
    None where it cannot be made. Nothing in it is secret: the child's side is the learner's side."""
    import shutil
    import tempfile

    path = _file()
    if path is None:
        return None
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        tree = tempfile.mkdtemp(prefix="tree-", dir=os.path.dirname(path))
        os.chmod(tree, 0o755)
        for source in child_modules:
            copy = os.path.join(tree, "grader", os.path.relpath(source, grader_dir))
            os.makedirs(os.path.dirname(copy), mode=0o755, exist_ok=True)
            shutil.copy2(source, copy)
        os.makedirs(os.path.join(tree, "etc"), mode=0o755)
        for source in system_files:
            copy = os.path.join(tree, "etc", os.path.relpath(source, "/etc"))
            if os.path.isdir(source):
                shutil.copytree(source, copy)
            elif os.path.isfile(source):
                shutil.copy2(source, copy)
    except (OSError, ValueError, shutil.Error):
        return None
    return tree


def start(mode: str) -> tuple | None:
    """The one-off `grade`'s child for sandbox mode `mode`, started at once behind the kept sandbox (with os, and
    os.posix_spawn where there is one): (the command prefix, the child); None where no kept decision holds (then
    grader.boundary.first_child asks the door)."""
    prefix = wrapper(mode)
    if prefix is None:
        return None
    from grader.boundary.spawn import start_child

    return prefix, start_child(KeptSandbox(prefix))


class KeptSandbox:
    """A kept sandbox's command prefix as a spawn CommandWrapper (the child gets a /tmp of its own)."""

    available = True

    def __init__(self, prefix: list[str]) -> None:
        self.prefix = prefix

    def __call__(self, command: list[str]) -> list[str]:
        return [*self.prefix, *command]
