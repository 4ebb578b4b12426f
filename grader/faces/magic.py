"""`%load_ext grader`, then `%grade ch06` in Jupyter, JupyterLab, VS Code notebooks, Colab or a terminal
IPython: the `grade` command in a cell, its result shown inline.

The kernel never grades: `%grade` hands its arguments, the kernel's folder, the names of the functions
the notebook defined itself and the cells the kernel ran (IPython's history, in order) to a resident
grading process of its own (grader.faces.notebook_server), which grades in sandboxed children as `grade chNN`
does. A chapter whose functions the notebook defines is graded from those cells (what the kernel ran,
in the order it ran it: Colab, or a notebook outside any exercises/ folder); any other from its file.
The result displays itself (IPython's rich display): the report's HTML fragment with plots in a
notebook front end, text in a terminal IPython.

Loading the extension also lets the kernel import a chapter kept as a notebook (`from ch03_jacobian
import ...` finds ch03_jacobian.ipynb where there is no .py), as the grader does. Only the standard
library here and IPython, which the `[notebook]` extra installs.
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field

ANSWER_SECONDS = 600.0  # a run is bounded far below this (grader.boundary.session.Limits); past it the process is replaced


@dataclass
class GradeResult:
    """What `%grade` returns: it shows itself as the report (HTML where the front end shows HTML, text
    elsewhere); `score`, `max_score` and `all_passed` are the report's."""

    text: str
    html: str = ""
    score: float = 0.0
    max_score: float = 0.0
    all_passed: bool = False
    data: dict = field(default_factory=dict, repr=False)

    def _repr_html_(self) -> str | None:
        return self.html or None

    def _repr_pretty_(self, printer, cycle: bool) -> None:
        printer.text(self.text.rstrip("\n"))

    def __repr__(self) -> str:
        return self.text.rstrip("\n")


class _Process:
    """The resident grading process (grader.faces.notebook_server) and its pipes; started again if it died."""

    def __init__(self) -> None:
        self.process: subprocess.Popen | None = None
        self.lock = threading.Lock()

    def start(self) -> None:
        if self.process is not None and self.process.poll() is None:
            return
        grader_parent = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (grader_parent, env.get("PYTHONPATH", "")) if p)
        env.pop("MPLBACKEND", None)  # the kernel's inline backend is not the report's
        from grader.system import process_groups

        options: dict = {"start_new_session": True} if process_groups() else {
            "creationflags": getattr(subprocess, "CREATE_NEW_PROCESS_GROUP", 0)}
        self.process = subprocess.Popen([sys.executable, "-m", "grader.faces.notebook_server", "--warm"],
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                        env=env, **options)
        from grader.system import StreamReader

        # one reader for the process's life: where pipes cannot be polled (Windows) it is a thread reading ahead,
        # and a second one would take the next answer from the first
        self.answers = StreamReader(self.process.stdout)
        self.unread = b""

    def ask(self, request: dict) -> dict:
        with self.lock:
            for attempt in (1, 2):
                self.start()
                try:
                    self.process.stdin.write((json.dumps(request) + "\n").encode("utf-8"))
                    self.process.stdin.flush()
                    line = self._answer(ANSWER_SECONDS)
                except KeyboardInterrupt:
                    self.stop()
                    raise
                except (OSError, TimeoutError):
                    line = b""
                if line:
                    return json.loads(line)
                self.stop()
            return {"error": "the grading process ended without an answer; run %grade again"}

    def _answer(self, timeout: float) -> bytes:
        """The grading process's next line (b"" if it ended); TimeoutError past `timeout`."""
        end = time.monotonic() + timeout
        while b"\n" not in self.unread:
            chunk = self.answers.read(end - time.monotonic())
            if not chunk:
                return b""
            self.unread += chunk
        line, self.unread = self.unread.split(b"\n", 1)
        return line + b"\n"

    def stop(self) -> None:
        if self.process is None:
            return
        try:
            self.process.kill()
        except OSError:
            pass
        self.process.wait()
        for stream in (self.process.stdin, self.process.stdout):
            try:
                stream.close()
            except OSError:
                pass
        self.process = None


_PROCESS = _Process()


def defined_functions(namespace: dict) -> list[str]:
    """Names of the functions the notebook itself defined (not imported from a module)."""
    import types

    return sorted(name for name, value in namespace.items()
                  if isinstance(value, types.FunctionType) and getattr(value, "__module__", None) == "__main__")


def kernel_cells(shell) -> list[tuple[str, str]]:
    """The cells the kernel ran, in order, as typed ("In [N]", source)."""
    history = getattr(shell.history_manager, "input_hist_raw", None) or []
    return [(f"In [{n}]", source) for n, source in enumerate(history) if n and source.strip()]


def grade(line: str, shell=None) -> GradeResult:
    """`%grade ARGS`: grade as `grade ARGS` does, in the resident grading process."""
    from IPython.core.error import UsageError

    if shell is None:
        from IPython import get_ipython

        shell = get_ipython()
    formatter = getattr(shell, "display_formatter", None)
    html = "text/html" in (getattr(formatter, "active_types", None) or [])
    request = {"args": shlex.split(line, posix=os.name == "posix"), "cwd": os.getcwd(), "html": html,
               "defined": defined_functions(shell.user_ns), "cells": kernel_cells(shell)}
    answer = _PROCESS.ask(request)
    if "error" in answer:
        raise UsageError(answer["error"])
    return GradeResult(answer.get("text", ""), answer.get("html", ""), answer.get("score", 0.0),
                       answer.get("max_score", 0.0), bool(answer.get("all_passed")), answer)


# ------------------------------------------------------------------------------ chapters kept as notebooks

class NotebookFinder:
    """Imports a chapter kept as a notebook (`ch03_jacobian.ipynb`) in the kernel, where there is no .py of
    that name, its code cells as the grader reads them (grader.notebook). Placed after the usual finders."""

    @classmethod
    def find_spec(cls, fullname: str, path=None, target=None):
        import importlib.util
        import re

        name = fullname.rpartition(".")[2]
        if not re.fullmatch(r"ch\d\d_\w+", name):
            return None
        for folder in (path or sys.path):
            candidate = os.path.join(folder or os.getcwd(), f"{name}.ipynb")
            if os.path.isfile(candidate):
                return importlib.util.spec_from_loader(fullname, _NotebookLoader(candidate), origin=candidate)
        return None


class _NotebookLoader:
    def __init__(self, path: str) -> None:
        self.path = path

    def create_module(self, spec):
        return None

    def exec_module(self, module) -> None:
        import linecache

        from grader import notebook

        with open(self.path, "rb") as handle:
            source = notebook.convert(handle.read(), self.path)
        filename = f"{self.path} (its code cells)"
        linecache.cache[filename] = (len(source.text), None, source.text.splitlines(True), filename)
        module.__file__ = self.path
        exec(compile(source.text, filename, "exec"), module.__dict__)


def load(shell) -> None:
    """Register `%grade`, let the kernel import chapters kept as notebooks, and start the grading process."""
    shell.register_magic_function(lambda line: grade(line, shell), magic_kind="line", magic_name="grade")
    if NotebookFinder not in sys.meta_path:
        sys.meta_path.append(NotebookFinder)
    _PROCESS.start()


def unload(shell) -> None:
    _PROCESS.stop()
    if NotebookFinder in sys.meta_path:
        sys.meta_path.remove(NotebookFinder)
