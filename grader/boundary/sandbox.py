"""Isolation for learner code: the child runs inside bubblewrap where it is installed.

The sandbox is an allow-list. Its root is an empty file system; into it go, read-only, only what
the child needs: the system's shared libraries, the interpreter and its standard library, the
packages learner code may import (numpy, sympy and, where installed, jax or torch with what they
import), and the few grader modules the child itself runs (grader.boundary.child, grader.boundary.wire,
grader.catalogue, the fork server). Every other Python package folder appears empty. The learner's
files are not bound at all: they travel inside the request and the child writes them to its own
fresh /tmp. So no reference solution, quiz key, check or other learner's file exists in there,
wherever the course keeps them. Also: no network, its own PID and IPC namespaces (its processes all
die with it), a new session; run as root, learner code drops to uid/gid 65534 (nobody) with no
capabilities.

Without bubblewrap the child runs with the resource limits and process-tree kill of grader.boundary.session
only, as the invoking user, and the isolation line says that it can read what that user can.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import sys
import sysconfig

from grader.system import child_path

NOBODY = 65534
GRADER_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The grader modules the child (and the fork server) import, relative to grader/: nothing else of the grader is
# visible. The catalogue of callables a check may pass and the system's facts are leaves both sides use.
CHILD_MODULES = ("__init__.py", "catalogue.py", "system.py", "boundary/__init__.py", "boundary/child.py",
                 "boundary/confine.py", "boundary/forkserver.py", "boundary/spawn.py", "boundary/wire.py")
# What learner code may import (the contract: numpy, math, sympy, an autograd library), with what
# those import in turn.
LEARNER_PACKAGES = ("numpy", "sympy", "mpmath")
AUTOGRAD_PACKAGES = ("jax", "torch")
SYSTEM_LIBRARIES = ("/usr/lib", "/usr/lib64", "/usr/lib32", "/lib", "/lib64", "/lib32")
SYSTEM_FILES = ("/etc/ld.so.cache", "/etc/ld.so.conf", "/etc/ld.so.conf.d", "/etc/passwd", "/etc/group",
                "/etc/nsswitch.conf", "/etc/localtime")
TMP_SIZE = 256 << 20  # the learner's /tmp


def _exists(path: str) -> bool:
    return os.path.lexists(path)


def _inside(path: str, folder: str) -> bool:
    return path == folder or path.startswith(folder.rstrip(os.sep) + os.sep)


@functools.lru_cache(maxsize=1)
def _stdlib_dirs() -> tuple[str, ...]:
    paths = sysconfig.get_paths()
    found = {os.path.realpath(paths[k]) for k in ("stdlib", "platstdlib") if paths.get(k)}
    found |= {os.path.realpath(p) for p in sys.path if p.endswith((".zip", "lib-dynload"))}
    return tuple(sorted(p for p in found if _exists(p)))


def _module_locations(name: str) -> list[str]:
    """The files and folders that make importable top-level module `name`: its package folder (or
    file), a `name.libs` folder of vendored shared libraries, its *.dist-info."""
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):
        return []
    if spec is None:
        return []
    if spec.submodule_search_locations:
        places = [os.path.realpath(p) for p in spec.submodule_search_locations]
    elif spec.origin and os.path.isabs(spec.origin):
        places = [os.path.realpath(spec.origin)]
    else:
        return []  # built in
    found = []
    for place in places:
        found.append(place)
        parent = os.path.dirname(place)
        found += [os.path.join(parent, n) for n in (f"{name}.libs",) if os.path.isdir(os.path.join(parent, n))]
        try:
            found += [os.path.join(parent, n) for n in os.listdir(parent)
                      if n.endswith(".dist-info") and n.split("-")[0].lower().replace("_", "-") == name.lower()]
        except OSError:
            pass
    return found


def _autograd_modules() -> set[str]:
    """Top-level modules of the installed autograd libraries and everything they require (read from their
    *.dist-info as importlib.metadata would, without its import of the email package)."""
    roots = [name for name in AUTOGRAD_PACKAGES if importlib.util.find_spec(name) is not None]
    if not roots:
        return set()
    import re

    def key(name: str) -> str:
        return re.sub(r"[-_.]+", "-", name).lower()

    dist_infos: dict[str, str] = {}
    for folder in sys.path:
        try:
            names = os.listdir(folder or ".")
        except OSError:
            continue
        for n in names:
            if n.endswith(".dist-info"):
                dist_infos.setdefault(key(n.removesuffix(".dist-info").split("-")[0]), os.path.join(folder, n))

    def read(dist_info: str, name: str) -> str:
        try:
            with open(os.path.join(dist_info, name), encoding="utf-8", errors="replace") as file:
                return file.read()
        except OSError:
            return ""

    modules: set[str] = set()
    seen: set[str] = set()
    pending = list(roots)
    while pending:
        name = key(pending.pop())
        if name in seen or name not in dist_infos:
            continue
        seen.add(name)
        dist_info = dist_infos[name]
        top = read(dist_info, "top_level.txt").split() or _recorded_top_level(read(dist_info, "RECORD"))
        modules.update(t for t in top if t.isidentifier())
        for line in read(dist_info, "METADATA").split("\n\n", 1)[0].splitlines():
            if line.startswith("Requires-Dist:") and "extra ==" not in line:
                match = re.match(r"[A-Za-z0-9][A-Za-z0-9._-]*", line.removeprefix("Requires-Dist:").strip())
                if match:
                    pending.append(match.group(0))
    return modules


def _recorded_top_level(record: str) -> set[str]:
    """The first path component of each file a wheel's RECORD lists."""
    firsts = {line.split(",", 1)[0].replace("\\", "/").split("/", 1)[0] for line in record.splitlines()}
    return {f.removesuffix(".py") for f in firsts if f and not f.startswith(("..", "/")) and ".dist-info" not in f}


@functools.lru_cache(maxsize=1)
def _site_dirs() -> tuple[str, ...]:
    """Every folder of third-party packages the child could see: those on its path, and the
    site-packages inside the standard library's folder (pyenv and other installs keep it there)."""
    import glob

    found = [os.path.realpath(p) for p in child_path()]
    for stdlib in _stdlib_dirs():
        found += [os.path.join(stdlib, n) for n in ("site-packages", "dist-packages")]
    for library in SYSTEM_LIBRARIES:  # e.g. Debian's /usr/lib/python3/dist-packages
        found += glob.glob(os.path.join(library, "python3*", "*-packages"))
    stdlib = _stdlib_dirs()
    return tuple(p for p in dict.fromkeys(found) if os.path.isdir(p) and not (
        p in stdlib or p.endswith("lib-dynload")))


@functools.lru_cache(maxsize=1)
def learner_packages() -> tuple[str, ...]:
    """The package folders and files learner code may import, each where it is installed."""
    names = set(LEARNER_PACKAGES) | _autograd_modules()
    sites = _site_dirs()
    places = {p for name in sorted(names) for p in _module_locations(name)}
    return tuple(sorted(p for p in places if any(_inside(p, s) for s in sites)))


def _child_modules() -> tuple[str, ...]:
    """The grader modules the child runs, each with its compiled file where there is one (else the child
    compiles it at every start: it may not write the compiled file)."""
    sources = [os.path.join(GRADER_DIR, name) for name in CHILD_MODULES]
    compiled = [importlib.util.cache_from_source(path) for path in sources]
    return tuple(sources + [path for path in compiled if os.path.isfile(path)])


def _python_files() -> list[str]:
    """The interpreter (as invoked and its real file), a venv's pyvenv.cfg, the standard library and
    the folder of libpython."""
    executable = os.path.abspath(sys.executable)
    files = [executable, os.path.realpath(executable)]
    for folder in (os.path.dirname(executable), os.path.dirname(os.path.dirname(executable))):
        config = os.path.join(folder, "pyvenv.cfg")
        if os.path.isfile(config):
            files.append(config)
    files += list(_stdlib_dirs())
    libdir = sysconfig.get_config_var("LIBDIR")
    library = sysconfig.get_config_var("LDLIBRARY")
    if libdir and library and os.path.exists(os.path.join(libdir, library)):
        files += [os.path.join(libdir, n) for n in os.listdir(libdir) if n.startswith(library.split(".so")[0])]
    return [p for p in dict.fromkeys(files) if _exists(p)]


class Sandbox:
    """bubblewrap around a child's command line (a grader.boundary.spawn CommandWrapper). Made only by
    grader.boundary.door.choose, which decides whether learner code gets one."""

    available = True  # a wrapped child has a /tmp of its own

    def __init__(self, bwrap: str, setpriv: str | None = None, remember: str | None = None) -> None:
        """`remember`: the sandbox mode the one-off `grade` asked, whose command line is kept between commands
        (grader.boundary.kept); None: built here, kept nowhere."""
        self.bwrap = bwrap
        self.setpriv = setpriv
        self.drops_to_nobody = hasattr(os, "geteuid") and os.geteuid() == 0 and self.setpriv is not None
        self.remember = remember
        self._prefix: list[str] | None = None

    def describe(self) -> str:
        """The isolation line: what holds for learner code in here, per learner as well."""
        who = "as uid 65534" if self.drops_to_nobody else "as you"
        from grader.boundary.session import Limits

        limits = Limits()
        each = (f"; each learner in namespaces of its own (processes, IPC, keyring, a fresh {limits.tmp_bytes >> 20} MiB "
                f"/tmp), at most {limits.processes} processes and {limits.memory_bytes >> 20} MiB for all of them, "
                f"{limits.learner_seconds:g} s in all" if user_namespaces() else
                "; this kernel allows no user namespaces, so learners share the sandbox's uid, keyring and IPC and "
                "have no cap on their processes or memory as a whole")
        return ("isolation: bubblewrap sandbox, an allow-list: learner code sees the interpreter, numpy/sympy and its "
                f"own files only (no answers, no other learner, no network), {who}{each}")

    def scratch_dirs(self) -> list[str]:
        """The only folders learner code can write to inside the sandbox."""
        return ["/tmp", "/dev/shm"]

    def __call__(self, command: list[str]) -> list[str]:
        """`command` inside the sandbox."""
        return [*self.command_prefix(), *command]

    def command_prefix(self) -> list[str]:
        """bubblewrap with its arguments, up to the command it runs (the one kept, where it still holds)."""
        if self._prefix is None:
            from grader.boundary import kept

            prefix = kept.wrapper(self.remember) if self.remember else None
            if prefix is None:
                tree = kept.prepare_tree(_child_modules(), GRADER_DIR, SYSTEM_FILES) if self.remember else None
                prefix = [self.bwrap, *self.arguments(tree), "--", *self._drop()]
                if self.remember:  # the prepared folders are watched too: removed, the decision is made again
                    kept.keep(self.remember, prefix, self.watched() + ([tree] if tree else []), tree)
            self._prefix = prefix
        return self._prefix

    def watched(self) -> list[str]:
        """The paths whose change may change the allow-list: bubblewrap and setpriv, the interpreter, the folders
        packages are installed in or found through, the places of the bound packages, the standard library, the
        grader's child modules (and their compiled files' folders) and the system's files."""
        child = [os.path.dirname(p) for p in _child_modules()]
        places = [os.path.dirname(p) for p in learner_packages()]
        paths = [self.bwrap, self.setpriv or "", sys.executable, *child_path(), *_site_dirs(), *places,
                 *_stdlib_dirs(), *child, *_child_modules(), *SYSTEM_LIBRARIES, *SYSTEM_FILES]
        return sorted({p for p in paths if p})

    def _drop(self) -> list[str]:
        if not self.drops_to_nobody:
            return []
        return [self.setpriv, f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups",
                "--inh-caps=-all", "--bounding-set=-all"]

    def arguments(self, tree: str | None = None) -> list[str]:
        """bwrap's arguments: the allow-list of read-only binds, then the private, writable /tmp. `tree`: a folder
        holding copies of the child's grader modules (tree/grader) and of the system's files (tree/etc), bound as
        two folders instead of one bind each (grader.boundary.kept.prepare_tree)."""
        # /tmp first: the interpreter or its packages may live under it (a venv in /tmp) and are bound in below
        args: list[str] = ["--dev", "/dev", "--proc", "/proc", "--perms", "01777", "--size", str(TMP_SIZE),
                           "--tmpfs", "/tmp"]
        bound: list[str] = []
        made: set[str] = {"/", "/tmp"}

        masks: list[str] = []

        def there(folder: str) -> bool:
            """Whether `folder` exists in the sandbox: made, or inside a bound tree and not hidden by a mask."""
            return folder in made or (any(_inside(folder, b) for b in bound)
                                      and not any(_inside(folder, m) and folder != m for m in masks))

        def parents(path: str) -> None:
            """Make the folders above `path` traversable (bwrap would make them 0700)."""
            missing = []
            folder = os.path.dirname(path)
            while not there(folder):
                missing.append(folder)
                folder = os.path.dirname(folder)
            for folder in reversed(missing):
                args.extend(["--perms", "0755", "--dir", folder])
                made.add(folder)

        def bind(path: str) -> None:
            if any(_inside(path, b) for b in bound):
                return
            parents(path)
            if os.path.islink(path) and os.path.dirname(path) == "/":  # /lib -> usr/lib on merged-/usr systems
                args.extend(["--symlink", os.readlink(path), path])
                bind(os.path.realpath(path))
                return
            args.extend(["--ro-bind", path, path])
            bound.append(path)

        for path in SYSTEM_LIBRARIES + (() if tree else SYSTEM_FILES):
            if _exists(path):
                bind(path)
        if tree:
            args.extend(["--ro-bind", os.path.join(tree, "etc"), "/etc"])
            made.add("/etc")
        if self.setpriv and self.drops_to_nobody:
            bind(self.setpriv)
        for path in _python_files():
            bind(path)
        # Every folder of third-party packages is empty in here, then the allowed packages come back.
        masked = [folder for folder in _site_dirs() if any(_inside(folder, b) for b in bound)]
        for folder in masked:
            args.extend(["--perms", "0755", "--tmpfs", folder])
            masks.append(folder)
            made.add(folder)
        for path in learner_packages() + ((os.path.join(tree, "grader"),) if tree else _child_modules()):
            inside = GRADER_DIR if tree and path == os.path.join(tree, "grader") else path
            parents(inside)
            args.extend(["--ro-bind", path, inside])
        for folder in masked:
            args.extend(["--remount-ro", folder])
        args.extend(["--remount-ro", "/",
                     "--setenv", "HOME", "/tmp",
                     "--unshare-ipc", "--unshare-pid", "--unshare-net", "--unshare-uts", "--unshare-cgroup-try",
                     "--die-with-parent", "--new-session", "--chdir", "/tmp"])
        return args


def user_namespaces() -> bool:
    """Whether an unprivileged process may create a user namespace here (grader.boundary.confine needs one)."""
    def read(path: str, default: str) -> str:
        try:
            with open(path, encoding="utf-8") as handle:
                return handle.read().strip()
        except OSError:
            return default

    return (read("/proc/sys/user/max_user_namespaces", "0") not in ("0", "")
            and read("/proc/sys/kernel/unprivileged_userns_clone", "1") == "1"
            and read("/proc/sys/kernel/apparmor_restrict_unprivileged_userns", "0") == "0")


def probe(wrap, seconds: float = 30.0, secrets: tuple[str, ...] = ()) -> str | None:
    """None when a child interpreter started as sessions start theirs (wrapped by `wrap`: a Sandbox, a
    grader.boundary.dropped.DroppedUser, or None) imports numpy and the child's side and can read none of
    `secrets` (the references, keys and course file); else why not, in one paragraph (then no learner is
    graded that way)."""
    import subprocess

    from grader.boundary.spawn import INTERPRETER

    code = (f"import sys; sys.path[:] = {child_path()!r}; import numpy, grader.boundary.child, os\n"
            f"for path in {list(secrets)!r}:\n"
            "    try:\n        os.listdir(path) if os.path.isdir(path) else open(path, 'rb').close()\n"
            "        print('readable:', path)\n    except OSError:\n        pass\nprint('ready')")
    command = [sys.executable, *INTERPRETER, "-c", code]
    if wrap is not None:
        command = wrap(command)
    try:
        done = subprocess.run(command, capture_output=True, text=True, encoding="utf-8", errors="replace", timeout=seconds,
                              stdin=subprocess.DEVNULL)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"the sandboxed interpreter did not start: {exc}"
    lines = done.stdout.split("\n")
    readable = [line.split(": ", 1)[1] for line in lines if line.startswith("readable: ")]
    if done.returncode == 0 and "ready" in lines:
        return None if not readable else (f"learner code could read {', '.join(readable[:3])}: those must be readable "
                                          "by root only")
    said = " ".join((done.stderr or done.stdout).split())[-600:]
    return f"the sandboxed interpreter did not start (exit status {done.returncode}): {said or 'no message'}"
