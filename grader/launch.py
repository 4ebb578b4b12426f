"""Entry point of `grade`: starts the grading child (and for --html the drawing process) before the heavier
imports (click, numpy).

The child's own startup (interpreter, numpy) then overlaps ours instead of following it. If the guess at the
submission turns out wrong, the CLI discards it.
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

from grader.spawn import SINGLE_THREADED_BLAS
from grader.submission import Submission

if TYPE_CHECKING:
    from grader.runner import Session

_OTHER_COMMANDS = {"list", "quiz", "batch", "release", "gradescope", "classroom", "submit", "--help", "-h",
                   "--version"}
_prestarted: tuple | None = None  # (submission, what grader.spawn.start_child returned, its sandbox)


def _guess(args: list[str]) -> tuple | None:
    if not args or args[0] in _OTHER_COMMANDS or any(a in ("--help", "-h") for a in args):
        return None
    if args[0] == "run":
        args = args[1:]
    from grader.sandbox import learner_sandbox
    from grader.spawn import start_child
    from grader.submission import SubmissionNotFound, locate

    directory = None
    for i, arg in enumerate(args):
        if arg == "--submission" and i + 1 < len(args):
            directory = args[i + 1]
        elif arg.startswith("--submission="):
            directory = arg.split("=", 1)[1]
    try:
        submission = locate(directory, "--solutions" in args)
        wrap = None if "--no-sandbox" in args else learner_sandbox()
        return submission, start_child(submission, wrap), wrap
    except (SubmissionNotFound, OSError):
        return None


def _draws_figures(args: list[str]) -> bool:
    """Whether the command grades once and writes an HTML report (not --watch, which may never write one)."""
    if not args or args[0] in _OTHER_COMMANDS or "--watch" in args or any(a in ("--help", "-h") for a in args):
        return False
    return any(a == "--html" or a.startswith("--html=") for a in args)


def take(submission: Submission, **session_options) -> Session | None:
    """A Session around the prestarted child if it serves `submission`; otherwise None."""
    global _prestarted
    prestarted, _prestarted = _prestarted, None
    if prestarted is None:
        return None
    from grader.runner import Session

    submission_started, started, wrap = prestarted
    session = Session(submission_started, started=started, wrap=wrap, **session_options)
    if submission_started == submission:
        return session
    session.close()
    return None


def main() -> None:
    global _prestarted
    # before anything here imports numpy: the grader's own BLAS threads would only spin beside the child
    os.environ.update(SINGLE_THREADED_BLAS)
    if _draws_figures(sys.argv[1:]):  # matplotlib's import, the report's longest step, starts first
        from grader.render import drawer

        drawer.start()
    _prestarted = _guess(sys.argv[1:])
    from grader.cli import main as cli_main

    code: int | str | None = 0
    try:
        cli_main()
    except SystemExit as exc:
        code = exc.code
    finally:
        take(Submission(None))  # stops a prestarted child nobody took
        if "grader.render.drawer" in sys.modules:  # and a drawing process nobody used (no atexit after os._exit)
            sys.modules["grader.render.drawer"].stop_unused()
    # Leave without the interpreter's teardown of every imported module (numpy's is slow):
    # everything is written and every child is stopped by now.
    if isinstance(code, str):
        print(code, file=sys.stderr)
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code or 0)
