"""Emulated systems for the tests: the grader run on Linux as Windows' or macOS's CPython would run it.

There is no Windows or macOS machine here. What each system's standard library lacks is read from
typeshed's stdlib stubs (mypy ships them; the field's machine-readable record of what every platform's
standard library has: each platform-specific name is guarded by `if sys.platform == "win32"`, `!= "darwin"`,
`== "linux"` ..., and `sys.version_info` tests), evaluated for this interpreter's version on Linux and on the
emulated platform: a name Linux's stubs define and the platform's do not is absent there, and a module that
defines nothing there does not import.

The emulation takes those names away from the code under test only, as a view: the grader (`grader`,
`grader.*`), learner code and `python -c` programs get modules without them (so `hasattr(os, "fork")` is
False and `import resource` fails), while the standard library and installed packages keep Linux's, which
their own internals need. What differs in behaviour is emulated for everyone, from the platforms'
documented behaviour:
- Windows: Popen refuses pass_fds, preexec_fn, start_new_session, process_group, user, group and umask;
  Popen.kill/terminate/send_signal end the one process, and a process so ended exits with status 1
  (TerminateProcess); select() takes sockets only (pipes raise WinError 10038); multiprocessing starts by
  "spawn" only; tempfile.TemporaryFile is a named file; text without an encoding (open, pipes, redirected
  stdout) is in the ANSI code page cp1252, strict, unless UTF-8 mode is on; ctypes.CDLL(None) raises (no
  C library by that name); there is no /proc and no bubblewrap.
- macOS: multiprocessing starts by "spawn" by default (fork after system libraries is unsafe); no
  bubblewrap, no setpriv, no prctl in the C library, AF_UNIX socket pairs of SOCK_SEQPACKET are refused, no
  /proc.
Every Python the emulated process starts gets the same emulation: through `sitecustomize` on PYTHONPATH
(spawned workers, `python -m ...`), and, for interpreters started isolated (-I -S, as the learner's child),
by prefixing their `-c` program.

Not emulated (the platforms differ there too, and nothing here can show it): path syntax and case-insensitive
file names, Windows file locking and sharing modes, job objects and the rest of ctypes.windll, sys.platform and
os.name (still Linux's), macOS's unenforced RLIMIT_AS and RLIMIT_DATA, the console's own encoding (only pipes
and files are emulated), Windows' process creation cost.
"""

from __future__ import annotations

import ast
import atexit
import functools
import os
import shutil
import sys
import tempfile
from pathlib import Path

PLATFORMS = {"windows": "win32", "macos": "darwin"}
# The standard library modules whose surface the emulation takes from the code under test: what grader/ and
# learner code use to start, wait for, signal and read processes, and to find out what the system offers.
MODULES = ("os", "signal", "select", "selectors", "socket", "subprocess", "tempfile", "multiprocessing", "time",
           "shutil", "mmap", "errno", "stat", "resource", "fcntl", "pwd", "grp", "termios", "tty", "pty", "posix",
           "_posixsubprocess", "_posixshmem", "syslog", "crypt", "spwd", "nis", "readline", "curses", "_curses")


def typeshed() -> Path:
    """typeshed's stdlib stubs, as the installed mypy ships them."""
    import mypy

    return Path(mypy.__file__).resolve().parent / "typeshed" / "stdlib"


class _Guard:
    """The `if` tests of typeshed's stubs, decided for one platform and Python version."""

    def __init__(self, platform: str, version: tuple[int, int]) -> None:
        self.platform, self.version = platform, version

    def decide(self, test: ast.expr) -> bool | None:
        """True or False for a platform or version test; None for anything else (both branches count)."""
        if isinstance(test, ast.BoolOp):
            values = [self.decide(v) for v in test.values]
            if isinstance(test.op, ast.And):
                return False if False in values else None if None in values else True
            return True if True in values else None if None in values else False
        if isinstance(test, ast.UnaryOp) and isinstance(test.op, ast.Not):
            value = self.decide(test.operand)
            return None if value is None else not value
        if isinstance(test, ast.Call) and isinstance(test.func, ast.Attribute) and test.func.attr == "startswith" \
                and ast.unparse(test.func.value) == "sys.platform" and test.args \
                and isinstance(test.args[0], ast.Constant):
            return self.platform.startswith(test.args[0].value)
        if not (isinstance(test, ast.Compare) and len(test.ops) == 1):
            return None
        left, op, right = ast.unparse(test.left), test.ops[0], test.comparators[0]
        if left == "sys.platform" and isinstance(right, ast.Constant):
            if isinstance(op, ast.Eq):
                return self.platform == right.value
            if isinstance(op, ast.NotEq):
                return self.platform != right.value
        if left == "sys.version_info" and isinstance(right, ast.Tuple):
            wanted = tuple(e.value for e in right.elts if isinstance(e, ast.Constant))
            compare = {ast.GtE: lambda a, b: a >= b, ast.Gt: lambda a, b: a > b, ast.Lt: lambda a, b: a < b,
                       ast.LtE: lambda a, b: a <= b}.get(type(op))
            return None if compare is None else compare(self.version[:len(wanted)], wanted)
        return None

    def names(self, body: list[ast.stmt]) -> set[str]:
        """The public names a stub's statements define here."""
        found: set[str] = set()
        for node in body:
            if isinstance(node, ast.If):
                decided = self.decide(node.test)
                if decided is not False:
                    found |= self.names(node.body)
                if decided is not True:
                    found |= self.names(node.orelse)
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                found.add(node.name)
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                found.add(node.target.id)
            elif isinstance(node, ast.Assign):
                found |= {t.id for t in node.targets if isinstance(t, ast.Name)}
            elif isinstance(node, ast.ImportFrom):  # `from x import y as y` is a re-export in a stub
                found |= {a.asname for a in node.names if a.asname and a.asname == a.name}
        return {name for name in found if not name.startswith("_") or name.startswith("__")}


def _stub(module: str) -> Path | None:
    base = typeshed().joinpath(*module.split("."))
    for candidate in (base.with_suffix(".pyi"), base / "__init__.pyi"):
        if candidate.is_file():
            return candidate
    return None


@functools.lru_cache(maxsize=None)
def surface(route: str) -> tuple[dict[str, tuple[str, ...]], tuple[str, ...]]:
    """(per module, the names Linux's stubs define and `route`'s do not; the modules `route` lacks), for this
    Python version."""
    version = sys.version_info[:2]
    linux, other = _Guard("linux", version), _Guard(PLATFORMS[route], version)
    missing: dict[str, tuple[str, ...]] = {}
    absent = []
    for module in MODULES:
        path = _stub(module)
        if path is None:
            continue
        body = ast.parse(path.read_text(encoding="utf-8")).body
        here, there = linux.names(body), other.names(body)
        if here and not there - {"sys"}:
            absent.append(module)
        elif here - there:
            missing[module] = tuple(sorted(here - there))
    if route == "windows":  # typeshed leaves curses unguarded (windows-curses); Windows' CPython has none
        absent += [m for m in ("curses", "_curses") if m not in absent]
    return missing, tuple(absent)


# The emulation itself, run first in every emulated interpreter (ROUTE, MISSING and ABSENT are set before it).
_PRELUDE = r'''
import builtins, errno as _errno, io as _io, os as _os, sys as _sys, types as _types
import ctypes as _ctypes, multiprocessing as _mp, select as _select, selectors as _selectors, shutil as _shutil
import socket as _socket, subprocess as _subprocess, sysconfig as _sysconfig, tempfile as _tempfile

_FOLDERS = {}
def _library_folders():
    """The standard library's folders and every folder of installed packages on the path (as it is now: an
    isolated child sets its path after this runs)."""
    key = tuple(_sys.path)
    if key not in _FOLDERS:
        paths = _sysconfig.get_paths()
        found = {paths[k] for k in ("stdlib", "platstdlib", "purelib", "platlib") if paths.get(k)}
        found |= {p for p in _sys.path if p.endswith(("site-packages", "dist-packages", "lib-dynload"))}
        _FOLDERS[key] = tuple(sorted({_os.path.realpath(p) for p in found}))
    return _FOLDERS[key]

def _is_subject(globals_):
    """Whether the importing code is under test: the grader, learner code, a -c program; not the standard
    library or an installed package other than the grader."""
    name = (globals_ or {}).get("__name__") or "__main__"
    if name == "grader" or name.startswith("grader.") or name == "__main__":
        return True
    file = (globals_ or {}).get("__file__")
    if not file:  # a frozen or built-in module of the standard library
        return False
    file = _os.path.realpath(file)
    return not any(file.startswith(folder + _os.sep) for folder in _library_folders())

class _View(_types.ModuleType):
    """A module as the emulated platform's code sees it: without the names that platform lacks."""
    def __init__(self, module, missing):
        super().__init__(module.__name__, module.__doc__)
        object.__setattr__(self, "_module", module)
        object.__setattr__(self, "_missing", frozenset(missing))
    def __getattr__(self, name):
        if name in self._missing:
            raise AttributeError(f"module {self._module.__name__!r} has no attribute {name!r}")
        return getattr(self._module, name)
    def __setattr__(self, name, value):
        setattr(self._module, name, value)
    def __dir__(self):
        return [n for n in dir(self._module) if n not in self._missing]

_VIEWS = {}
for _name, _names in MISSING.items():
    try:
        _VIEWS[_name] = _View(__import__(_name), _names)
    except ImportError:
        pass

_real_import = builtins.__import__
def _import(name, globals=None, locals=None, fromlist=(), level=0):
    if level == 0 and _is_subject(globals):
        top = name.split(".")[0]
        if name in ABSENT or top in ABSENT:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        module = _real_import(name, globals, locals, fromlist, level)
        shown = name if fromlist else top  # `import os.path` binds os; `from os import fork` asks os
        return _VIEWS.get(shown, module) if shown == module.__name__ else module
    return _real_import(name, globals, locals, fromlist, level)
builtins.__import__ = _import

import importlib as _importlib
_real_import_module = _importlib.import_module
def _import_module(name, package=None):
    module = _real_import_module(name, package)
    if name in ABSENT:
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    return _VIEWS.get(name, module) if _is_subject(_sys._getframe(1).f_globals) else module
_importlib.import_module = _import_module

# -- behaviour, for everyone
_NO_PROC = ("/proc",)
def _no_proc(path):
    try:
        text = _os.fsdecode(path)
    except TypeError:
        return False
    return any(text == p or text.startswith(p + "/") for p in _NO_PROC)
_listdir, _scandir, _open = _os.listdir, _os.scandir, builtins.open
def _listdir_no_proc(path="."):
    if _no_proc(path):
        raise FileNotFoundError(_errno.ENOENT, "No such file or directory", path)
    return _listdir(path)
def _scandir_no_proc(path="."):
    if _no_proc(path):
        raise FileNotFoundError(_errno.ENOENT, "No such file or directory", path)
    return _scandir(path)
_os.listdir, _os.scandir = _listdir_no_proc, _scandir_no_proc
_stat, _lstat = _os.stat, _os.lstat
def _stat_no_proc(path, *args, **kwargs):
    if _no_proc(path):
        raise FileNotFoundError(_errno.ENOENT, "No such file or directory", path)
    return _stat(path, *args, **kwargs)
def _lstat_no_proc(path, *args, **kwargs):
    if _no_proc(path):
        raise FileNotFoundError(_errno.ENOENT, "No such file or directory", path)
    return _lstat(path, *args, **kwargs)
_os.stat, _os.lstat = _stat_no_proc, _lstat_no_proc
_os_open = _os.open
def _os_open_no_proc(path, *args, **kwargs):
    if _no_proc(path):
        raise FileNotFoundError(_errno.ENOENT, "No such file or directory", path)
    return _os_open(path, *args, **kwargs)
_os.open = _os_open_no_proc

_which = _shutil.which
_shutil.which = lambda name, *a, **k: None if _os.path.basename(str(name)) in ("bwrap", "setpriv") else _which(
    name, *a, **k)

_CDLL = _ctypes.CDLL
class _CLibrary(_CDLL):
    def __init__(self, name, *args, **kwargs):
        if name is None and ROUTE == "windows":
            raise TypeError("LoadLibrary() argument 1 must be str, not None")
        super().__init__(name, *args, **kwargs)
    def __getattr__(self, name):
        if name == "prctl":
            raise AttributeError(f"{name}: symbol not found")
        return super().__getattr__(name)
_ctypes.CDLL = _CLibrary

if ROUTE == "macos":
    _mp.set_start_method("spawn", force=True)
    _socketpair = _socket.socketpair
    def _socketpair_without_seqpacket(family=None, type=_socket.SOCK_STREAM, proto=0):
        if type == _socket.SOCK_SEQPACKET:
            raise OSError(_errno.EPROTONOSUPPORT, "Protocol not supported")
        return _socketpair(*(a for a in (family, type, proto) if a is not None))
    _socket.socketpair = _socketpair_without_seqpacket

if ROUTE == "windows":
    _mp.set_start_method("spawn", force=True)
    _mp.get_all_start_methods = lambda: ["spawn"]
    _get_context = _mp.get_context
    def _spawn_only(method=None):
        if method not in (None, "spawn"):
            raise ValueError(f"cannot find context for {method!r}")
        return _get_context(method)
    _mp.get_context = _spawn_only
    _tempfile.TemporaryFile = _tempfile.NamedTemporaryFile

    _real_select = _select.select
    def _sockets_only(r, w, x, *timeout):
        import stat as _stat
        for item in [*r, *w, *x]:
            fd = item if isinstance(item, int) else item.fileno()
            if not _stat.S_ISSOCK(_os.fstat(fd).st_mode):
                raise OSError(10038, "An operation was attempted on something that is not a socket")
        return _real_select(r, w, x, *timeout)
    _select.select = _sockets_only
    _selectors.SelectSelector._select = staticmethod(_sockets_only)
    _selectors.DefaultSelector = _selectors.SelectSelector

    _popen_init = _subprocess.Popen.__init__
    def _windows_popen(self, args, *more, **options):
        for key, unset in (("pass_fds", ()), ("preexec_fn", None), ("start_new_session", False),
                           ("process_group", None), ("user", None), ("group", None), ("umask", -1)):
            if options.get(key, unset) not in (unset, None):
                raise ValueError(f"{key} is not supported on Windows platforms")
        _popen_init(self, _emulated(args), *more, **options)
    def _terminate_process(self, sig=None):
        if self.returncode is None:
            try:
                _os.kill(self.pid, 9)
            except ProcessLookupError:
                pass
    _handle_exitstatus = _subprocess.Popen._handle_exitstatus
    def _exit_status(self, *args, **kwargs):
        _handle_exitstatus(self, *args, **kwargs)
        if self.returncode is not None and self.returncode < 0:  # TerminateProcess(handle, 1)
            self.returncode = 1
    _subprocess.Popen.__init__ = _windows_popen
    _subprocess.Popen.send_signal = _subprocess.Popen.terminate = _subprocess.Popen.kill = _terminate_process
    _subprocess.Popen._handle_exitstatus = _exit_status

    if not _sys.flags.utf8_mode:  # text without an encoding is in the ANSI code page, strict
        for _stream in (_sys.stdout, _sys.stderr):
            if _stream is not None and hasattr(_stream, "reconfigure") and not _stream.isatty():
                _stream.reconfigure(encoding="cp1252", errors="strict")
        def _ansi_open(file, mode="r", buffering=-1, encoding=None, *args, **kwargs):
            if "b" not in mode and encoding in (None, "locale"):
                encoding = "cp1252"
            return _open(file, mode, buffering, encoding, *args, **kwargs)
        builtins.open = _io.open = _ansi_open
        _io.text_encoding = lambda encoding, stacklevel=2: "cp1252" if encoding in (None, "locale") else encoding
else:
    _popen_init = _subprocess.Popen.__init__
    def _emulated_popen(self, args, *more, **options):
        _popen_init(self, _emulated(args), *more, **options)
    _subprocess.Popen.__init__ = _emulated_popen

def _emulated(args):
    """An isolated interpreter started with -c gets the emulation first (site and PYTHONPATH do not reach it)."""
    if isinstance(args, list) and "-c" in args and _os.path.basename(str(args[0])).startswith("python"):
        at = args.index("-c") + 1
        return [*args[:at], f"EMULATION = {EMULATION!r}\nexec(EMULATION)\n" + args[at], *args[at + 1:]]
    return args
'''


def prelude(route: str) -> str:
    """The emulation as Python source: run it first, and the interpreter is `route`'s ("windows", "macos")."""
    missing, absent = surface(route)
    settings = f"ROUTE = {route!r}\nMISSING = {missing!r}\nABSENT = {absent!r}\n"
    body = settings + _PRELUDE
    return f"EMULATION = {body!r}\nexec(EMULATION)\n"


def _remove_in(pid: int, folder: Path) -> None:
    """Remove `folder` when the process `pid` exits (not a forked copy of it, which runs the same exit handlers)."""
    if os.getpid() == pid:
        shutil.rmtree(folder, ignore_errors=True)


@functools.lru_cache(maxsize=None)
def site_folder(route: str) -> str:
    """A folder whose sitecustomize.py is the emulation: on PYTHONPATH, every interpreter that reads site is
    `route`'s (spawned workers, `python -m grader ...`, `grade`)."""
    folder = Path(tempfile.mkdtemp(prefix=f"emulated-{route}-"))
    atexit.register(_remove_in, os.getpid(), folder)  # gone with the test process
    (folder / "sitecustomize.py").write_text(prelude(route), encoding="utf-8")
    return str(folder)


def environment(route: str, base: dict | None = None) -> dict:
    """The environment that makes a command run as on `route` ("linux": unchanged)."""
    env = dict(os.environ if base is None else base)
    if route != "linux":
        env["PYTHONPATH"] = os.pathsep.join(p for p in (site_folder(route), env.get("PYTHONPATH", "")) if p)
    return env


def grade_command(route: str, *arguments: str) -> list[str]:
    """A command line running `grade ARGUMENTS...`; run it with environment(route). On Windows and macOS, as a
    user who is not root, as a laptop's user is (tests.support.not_root)."""
    return _as_a_laptops_user(route, [sys.executable, "-m", "grader", *arguments])


def python_code(route: str, code: str) -> list[str]:
    """A command line running the Python program `code` as on `route` (with the emulation run first), on Windows and
    macOS as a user who is not root."""
    return _as_a_laptops_user(route, [sys.executable, "-c", (prelude(route) if route != "linux" else "") + code])


def _as_a_laptops_user(route: str, command: list[str]) -> list[str]:
    if route == "linux":
        return command
    from tests.support import not_root

    return not_root(command)
