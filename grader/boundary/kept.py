"""The door's last decision for a one-off `grade`, kept between commands: the sandbox's command line, built once.

grader.boundary.door.choose decides how learner code runs, and grader.boundary.sandbox builds bubblewrap's
allow-list from what is installed (the interpreter, its standard library, numpy, sympy, an autograd library
with what it requires, the child's own modules): some 50 read-only binds, found by asking the import system
and reading package metadata. That is the same command after command, so the one-off `grade` keeps the
decision, with the allow-list, in the user's cache folder; the next command's launcher (grader.launch) reads it
with os and json alone and starts the child before anything else is imported.

A kept decision holds only while what made it holds: the mode asked, the environment the door reads (the
grader's own settings, GRADER_*, and PATH), the user, the interpreter and its path, and the
modification times of every folder the allow-list was read from (an install or removal changes them) and of
bubblewrap itself. Anything else is a miss, and the door decides afresh. It is read and written by the one-off
command only (`remember`), never by batch, Gradescope or a resident boundary; like the grader's own files, it
is as safe as this user's cache folder (learner code can write it only where it ever ran unsandboxed as this
user, when it could as well have rewritten the grader).
"""

from __future__ import annotations

import json
import os
import sys

from grader.system import cache_folder

_NOT_READ_BY_THE_DOOR = ("GRADER_TRACE", "GRADER_CACHE_DIR")


def _file() -> str | None:
    folder = cache_folder("launch")
    return None if folder is None else os.path.join(folder, "decision.json")


def _condition(mode: str) -> list:
    """What the decision depends on besides the watched paths."""
    euid = os.geteuid() if hasattr(os, "geteuid") else None
    settings = sorted([k, v] for k, v in os.environ.items() if k.startswith("GRADER_") and k not in _NOT_READ_BY_THE_DOOR)
    return [mode, settings, os.environ.get("PATH"), euid, sys.executable, sys.version, sys.path]


def _stamp(paths: list[str]) -> list:
    stamp = []
    for path in paths:
        try:
            stamp.append([path, os.stat(path).st_mtime_ns])
        except OSError:
            stamp.append([path, None])
    return stamp


def wrapper(mode: str) -> list[str] | None:
    """The kept command prefix (bubblewrap, its arguments, the drop of privileges) for sandbox mode `mode`, if
    the decision still holds here; else None."""
    path = _file()
    if path is None:
        return None
    try:
        with open(path, encoding="utf-8") as handle:
            kept = json.load(handle)
    except (OSError, ValueError):
        return None
    if not isinstance(kept, dict) or kept.get("condition") != json.loads(json.dumps(_condition(mode))):
        return None
    watched, prefix = kept.get("watched"), kept.get("prefix")
    if not (isinstance(watched, list) and all(isinstance(p, str) for p in watched) and isinstance(prefix, list)
            and prefix and all(isinstance(a, str) for a in prefix)):
        return None
    if kept.get("stamp") != _stamp(watched):
        return None
    return prefix


def keep(mode: str, prefix: list[str], watched: list[str], tree: str | None = None) -> None:
    """Keep the door's decision for `mode`: the command prefix, the paths whose change undoes it and the prepared
    tree it binds (the trees of earlier decisions are removed). Failing to write is not an error."""
    path = _file()
    if path is None:
        return
    temporary = f"{path}.{os.getpid()}.tmp"
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(temporary, "w", encoding="utf-8") as handle:
            json.dump({"condition": _condition(mode), "watched": watched, "stamp": _stamp(watched),
                       "prefix": prefix}, handle)
        os.replace(temporary, path)
    except (OSError, TypeError, ValueError):
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
    """The one-off `grade`'s child for sandbox mode `mode`, started at once behind the kept sandbox (only os, json
    and subprocess imported): (the command prefix, the child); None where no kept decision holds (then
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
