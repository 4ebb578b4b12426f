"""The child side of the process boundary: import the learner's module, call it, report plain data.

This file runs in a separate interpreter (`python -I -S -c ...`, see grader.boundary.spawn), or in a child
forked from grader.boundary.forkserver. It reads one JSON request (grader.boundary.wire), writes the learner's files
that came with it into a fresh folder, points stdout/stderr at the capture file the parent opened,
and for each chapter imports the learner's module and calls the named functions on the arguments
the parent chose. Every outcome is written to the result pipe as one JSON line. Only numbers,
shapes and type names travel back: never pickle, never a learner object.

Nothing here decides whether an answer is right; that happens in the parent.
"""

from __future__ import annotations

import gc
import importlib
import importlib.machinery
import json
import os
import signal
import sys

import numpy as np  # noqa: F401  (loaded before any learner code, and before the request arrives)

from grader.boundary.wire import (
    COMPILING,
    DONE,
    IMPORT,
    IMPORT_FAILED,
    IMPORTED,
    MISSING_EVENT,
    RAISED_EVENT,
    RETURNED,
    T_OTHER,
    decode_argument,
    encode_value,
)


def _learner_frames(exc: BaseException, root: str) -> tuple[str, int | None, str | None]:
    """The traceback trimmed to frames in the submission's files, and the innermost such line and its file
    (relative to the submission: an error in an earlier chapter's file, imported by this one, is there). Walked
    here, not with the traceback module, whose import (linecache, tokenize) costs a stub's first error 20 ms."""
    frames = []
    tb = exc.__traceback__
    while tb is not None:
        code = tb.tb_frame.f_code
        if code.co_filename.startswith(root):
            frames.append((code.co_filename, tb.tb_lineno, code.co_name))
        tb = tb.tb_next
    lines = []
    for filename, lineno, name in frames:
        shown = os.path.relpath(filename, root)
        lines.append(f'  File "{shown}", line {lineno}, in {name}')
        line = _source_line(filename, lineno)
        if line:
            lines.append(f"    {line}")
    text = "\n".join(lines + [f"{type(exc).__name__}: {_safe_str(exc)}"])
    if not frames:
        return text, None, None
    return text, frames[-1][1], os.path.relpath(frames[-1][0], root).replace(os.sep, "/")


_SOURCES: dict[str, list[str]] = {}


def _source_line(filename: str, lineno: int | None) -> str:
    """Line `lineno` of a learner's file, stripped, as linecache gives it ("" where there is none)."""
    if filename not in _SOURCES:
        try:
            with open(filename, "rb") as handle:
                data = handle.read()
        except OSError:
            data = b""
        head = data.split(b"\n", 2)[:2]
        if any(b"coding" in line and line.lstrip().startswith(b"#") for line in head):  # a declared encoding
            import linecache

            _SOURCES[filename] = linecache.getlines(filename)
        else:
            _SOURCES[filename] = data.decode("utf-8-sig", "replace").splitlines()
    found = _SOURCES[filename]
    return found[lineno - 1].strip() if lineno and 0 < lineno <= len(found) else ""


def _safe_str(exc: BaseException) -> str:
    try:
        return str(exc)[:500]
    except BaseException:  # a learner's exception whose __str__ itself fails
        return "<message could not be shown>"


_MEMORY_LIMIT: list[int] = []  # the cap on memory written set by _apply_limits, if any


def describe_exception(exc: BaseException, root: str) -> dict:
    text, line, file = _learner_frames(exc, root)
    message = _safe_str(exc)
    if isinstance(exc, MemoryError) and _MEMORY_LIMIT:
        message = f"ran out of memory: the limit is {_MEMORY_LIMIT[0] / (1 << 30):g} GiB" + (f" ({message})" if message else "")
    return {
        "exception": type(exc).__name__,
        "bases": [c.__name__ for c in type(exc).__mro__][:8],
        "not_implemented": isinstance(exc, NotImplementedError),
        "message": message,
        "traceback": text,
        "line": line,
        "file": file,
    }


def _syntax_error(exc: SyntaxError, root: str) -> dict:
    shown = os.path.relpath(exc.filename, root).replace(os.sep, "/") if exc.filename else None
    text = f'  File "{shown or "?"}", line {exc.lineno}\n    {(exc.text or "").rstrip()}\nSyntaxError: {exc.msg}'
    return {"exception": type(exc).__name__, "not_implemented": False, "message": exc.msg or "",
            "traceback": text, "line": exc.lineno, "file": shown}


class _Catalogue:
    """Callables the parent may pass by name; loaded on first use."""

    def __init__(self) -> None:
        self._table: dict | None = None

    def __getitem__(self, name: str):
        if self._table is None:
            from grader.catalogue import CALLABLES
            self._table = CALLABLES
        return self._table[name]


def _emit(stream, record: dict) -> None:
    stream.write(json.dumps(record) + "\n")
    stream.flush()


def _redirect_output(capture_fd: int) -> None:
    """stdin from /dev/null; stdout and stderr into the capture file the parent opened."""
    null_in = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null_in, 0)
    os.dup2(capture_fd, 1)
    os.dup2(capture_fd, 2)
    os.close(null_in)
    os.close(capture_fd)


def _apply_limits(limits: dict) -> None:
    """Resource limits for learner code (POSIX only; a missing limit is simply not set)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - not POSIX
        return
    if hasattr(signal, "SIGXFSZ"):
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # an oversized write fails instead of killing us
    table = {
        "data_bytes": getattr(resource, "RLIMIT_DATA", None),  # written, not reserved (jax reserves much)
        "cpu_seconds": resource.RLIMIT_CPU,
        "file_size": resource.RLIMIT_FSIZE,
        "open_files": resource.RLIMIT_NOFILE,
        "core": resource.RLIMIT_CORE,
        "processes": resource.RLIMIT_NPROC,  # counted in the learner's own user namespace (grader.boundary.confine)
    }
    for key, which in table.items():
        value = limits.get(key)
        if value is None or which is None:
            continue
        try:
            resource.setrlimit(which, (value, value))
        except (ValueError, OSError):
            continue
        if key == "data_bytes":
            _MEMORY_LIMIT.append(value)


def _pin_package(root: str, package: str) -> None:
    """Make `package` the submission's own folder, whatever else on sys.path has that name.

    Without this, an `exercises` package elsewhere on the path (the project, an editable install)
    could shadow a submission's folder and grade the wrong files.
    """
    if package in sys.modules:
        return
    import importlib.util

    folder = os.path.join(root, package)
    init = os.path.join(folder, "__init__.py")
    spec = importlib.util.spec_from_file_location(
        package, init if os.path.isfile(init) else None, submodule_search_locations=[folder])
    if spec is None:  # no __init__.py: a namespace-like package of just this folder
        spec = importlib.machinery.ModuleSpec(package, None, is_package=True)
        spec.submodule_search_locations = [folder]
    module = importlib.util.module_from_spec(spec)
    sys.modules[package] = module
    try:
        if spec.loader is not None:
            spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[package]
        raise


def _helpers_of(chapter: dict) -> dict[str, frozenset[str]]:
    """The chapter's functions with helpers to watch for (the request's `helpers`, grader.boundary.wire), each without
    itself."""
    asked = chapter.get("helpers")
    if not isinstance(asked, dict):
        return {}
    return {function: frozenset(h for h in helpers if isinstance(h, str) and h != function)
            for function, helpers in asked.items() if isinstance(helpers, list)}


class _Watch:
    """Calls a learner function while noting which of the learner's functions `names` it entered, at any depth: a
    function of the submission's files (under `folder`) of that name, whichever module object holds it (an earlier
    chapter's file imported as `from .ch06_measurement import ...` or as `from ch06_measurement import ...`). Only
    during the calls of functions with helpers, and only function entries, never lines.

    Python 3.12 and later: sys.monitoring's PY_START, on from the first call watched to the end of the request (turning
    it on and off re-instruments every function run after, some 10 us a call), each code object that can be no helper
    (numpy's, the grader's, a learner's function of another name) turned off for good the first time it starts: a
    loop costs nothing after its first round, and an unwatched call nothing but its helpers' entries. Before 3.12: a
    profile function during a watched call only, removed as soon as every one of `names` was entered; until then
    each Python function's entry and each C call costs a call of it (a numpy-heavy call that never reaches its
    helper runs about 1.4 times as long)."""

    TOOL = 4  # a sys.monitoring tool id of no standard tool's (0, 1, 2 and 5: debuggers, coverage, profilers, optimizers)

    def __init__(self, folder: str, anywhere: frozenset[str]) -> None:
        self.folder = folder
        self.anywhere = anywhere  # every helper of every chapter of the request: no code object of these is turned off
        self.names: frozenset[str] = frozenset()  # those of the call watched now (none between calls)
        self.reached: set[str] = set()
        self.on = False  # sys.monitoring's events are on
        self.monitoring = monitoring = getattr(sys, "monitoring", None)
        if monitoring is not None:
            if monitoring.get_tool(self.TOOL) != "grader":
                try:
                    monitoring.use_tool_id(self.TOOL, "grader")
                except ValueError:  # another's (never learner code's: none has run yet): the profile function instead
                    self.monitoring = None
            if self.monitoring is not None:
                self.disable = monitoring.DISABLE
                monitoring.register_callback(self.TOOL, monitoring.events.PY_START, self._started)

    def _started(self, code, offset: int):
        name = code.co_name
        if name in self.anywhere and code.co_filename.startswith(self.folder):
            if name in self.names:
                self.reached.add(name)
            return None
        return self.disable  # no helper of any function of this request: never again

    def _profile(self, frame, event: str, arg) -> None:
        if event == "call":
            code = frame.f_code
            if code.co_name in self.names and code.co_filename.startswith(self.folder):
                self.reached.add(code.co_name)
                if len(self.reached) == len(self.names):  # nothing more to learn: the rest of the call runs unwatched
                    sys.setprofile(None)

    def call(self, function, args: list, kwargs: dict, names: frozenset[str], reached: set[str]):
        """function(*args, **kwargs), with `reached` filled with those of `names` it entered (also if it raises)."""
        monitoring = self.monitoring
        if monitoring is not None:
            if not self.on:
                monitoring.set_events(self.TOOL, monitoring.events.PY_START)
                self.on = True
            self.names, self.reached = names, reached
            try:
                return function(*args, **kwargs)
            finally:
                self.names = frozenset()
        self.names, self.reached = names, reached
        previous = sys.getprofile()
        sys.setprofile(self._profile)
        try:
            return function(*args, **kwargs)
        finally:
            sys.setprofile(previous)

    def close(self) -> None:
        if self.monitoring is not None and self.on:
            self.monitoring.set_events(self.TOOL, 0)
            self.on = False


def run(request: dict, out) -> None:
    root = os.path.realpath(request["root"])
    sys.path.insert(0, root)
    # the contract's plain form `from ch03_jacobian import ...` (also what runs as a script), last
    sys.path.append(os.path.join(root, request["package"]))
    sys.dont_write_bytecode = True
    catalogue = _Catalogue()
    helpers_of = {chapter["chapter"]: _helpers_of(chapter) for chapter in request["chapters"]}
    anywhere = frozenset(h for helpers in helpers_of.values() for names in helpers.values() for h in names)
    # the submission's files are under root (with the separator: not a sibling folder's)
    watch = _Watch(os.path.join(root, ""), anywhere) if anywhere else None
    for chapter in request["chapters"]:
        name = chapter["chapter"]
        _emit(out, {"event": IMPORT, "chapter": name})
        try:
            _pin_package(root, request["package"])
            module = importlib.import_module(f'{request["package"]}.{chapter["module"]}')
        except SyntaxError as exc:
            _emit(out, {"event": IMPORT_FAILED, "chapter": name, "error": _syntax_error(exc, root)})
            continue
        except BaseException as exc:  # SystemExit and KeyboardInterrupt from learner code too
            _emit(out, {"event": IMPORT_FAILED, "chapter": name, "error": describe_exception(exc, root)})
            continue
        # the libraries that compile a function on its first call (jax.jit, torch.compile): its first call gets more time
        _emit(out, {"event": IMPORTED, "chapter": name, "compiling": sorted(COMPILING & set(sys.modules))})
        helpers = helpers_of[name]
        for call in chapter["calls"]:
            index = call["index"]
            function = getattr(module, call["function"], None)
            if not callable(function):
                _emit(out, {"event": MISSING_EVENT, "chapter": name, "index": index})
                continue
            watched = helpers.get(call["function"]) if helpers else None
            reached: set[str] | None = set() if watched and watch is not None else None
            try:
                args = [decode_argument(a, catalogue) for a in call.get("args", [])]
                kwargs = {k: decode_argument(v, catalogue) for k, v in call.get("kwargs", {}).items()}
                if reached is None:
                    value = function(*args, **kwargs)
                else:
                    value = watch.call(function, args, kwargs, watched, reached)
                record = {"event": RETURNED, "chapter": name, "index": index, "value": encode_value(value)}
            except BaseException as exc:
                record = {"event": RAISED_EVENT, "chapter": name, "index": index,
                          "error": describe_exception(exc, root)}
            if reached is not None:
                record["reached"] = sorted(reached)
            try:
                _emit(out, record)
            except (TypeError, ValueError, OverflowError):
                _emit(out, {"event": RETURNED, "chapter": name, "index": index,
                            "value": {"t": T_OTHER, "type": "a value that cannot be encoded"},
                            **({"reached": record["reached"]} if reached is not None else {})})
    if watch is not None:
        watch.close()
    _flush_learner_output()  # before DONE: the parent may stop the process as soon as it reads it
    _emit(out, {"event": DONE})


def _flush_learner_output() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except BaseException:  # a learner may have replaced or closed them
            pass


def _write_files(files: dict, root: str) -> None:
    """Write the submission's files (relative path -> base64), sent in the request, under `root`."""
    import base64

    os.makedirs(root, mode=0o700, exist_ok=True)
    for relative, data in files.items():
        path = os.path.join(root, relative)
        if os.path.isabs(relative) or ".." in relative.split("/"):
            continue
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as handle:
            handle.write(base64.b64decode(data))


def serve(request_text: str, result_fd: int, capture_fd: int) -> None:
    """Grade one request and leave the process (never returns)."""
    request = json.loads(request_text)
    limits = dict(request.get("limits", {}))
    if request.get("confine"):  # in a sandbox: the learner's own namespaces, /tmp and caps (grader.boundary.confine)
        from grader.boundary.confine import enter

        if enter(limits, [p for p in sys.path if os.path.isabs(p)]) and limits.get("memory_bytes"):
            # memory used is capped for all processes together (its watchdog names what happened)
            limits.pop("data_bytes", None)
    out = os.fdopen(result_fd, "w", buffering=1, encoding="utf-8", newline="\n")
    _write_files(request["files"], request["root"])  # the learner's files come with the request
    os.chdir(request["root"])
    _redirect_output(capture_fd)
    _apply_limits(limits)
    # The collector was off since the interpreter started (spawn's boot line, the fork server's warm-up): numpy's
    # import and the request make tens of thousands of objects and no garbage. On again for learner code, whose
    # collections never walk what is frozen here.
    gc.freeze()
    gc.enable()
    run(request, out)
    out.close()
    os._exit(0)  # skip learner atexit handlers and finalizers


def main(argv: list[str] | None = None) -> None:
    """A spawned child. argv is [result pipe fd, capture file fd] (grader.boundary.spawn, posix), or
    ["--portable", capture file path]: then results go to what was stdout. The request arrives on stdin."""
    argv = sys.argv[1:] if argv is None else argv
    request = sys.stdin.buffer.read().decode("utf-8")
    if argv[0] == "--portable":
        result_fd = os.dup(1)  # the pipe to the parent, kept apart from what learner code prints
        capture_fd = os.open(argv[1], os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_BINARY", 0), 0o600)
        serve(request, result_fd, capture_fd)
    serve(request, int(argv[0]), int(argv[1]))


if __name__ == "__main__":
    main()
