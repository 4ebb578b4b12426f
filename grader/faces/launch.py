"""Entry point of `grade`: starts the grading child (and for --html the drawing process) before the heavier
imports (click, numpy).

The child's own startup (interpreter, numpy) then overlaps ours instead of following it. If the guess at the
submission turns out wrong, the CLI discards it.
"""

from __future__ import annotations

import gc
import os
import sys

from grader.faces.commands import grades_at_once
from grader.system import SINGLE_THREADED_BLAS, trace, traced


def _prestart(args: list[str]) -> None:
    """Start the learner's child for a command that grades at once (grader.faces.commands), held in
    grader.faces.prestart: behind the sandbox the door chose for the last such command (grader.boundary.kept), with
    nothing else imported, else as it decides now."""
    if not grades_at_once(args):
        return
    mode = "off" if "--no-sandbox" in args else "auto"
    from grader.boundary import kept
    from grader.faces import prestart

    try:
        started = kept.start(mode)
        if started is None:
            from grader import boundary

            started = boundary.first_child(mode)
        prestart.hold(mode, *started)
        trace("child started")
    except (OSError, RuntimeError):  # no child here as asked (grader.boundary.BoundaryUnavailable): the command says why
        pass


def _draws_figures(args: list[str]) -> bool:
    """Whether the command grades once and writes an HTML report (not --watch, which may never write one)."""
    if not grades_at_once(args) or "--watch" in args:
        return False
    return any(a == "--html" or a.startswith("--html=") for a in args)


def _figures_kept(args: list[str]) -> bool:
    """Whether the HTML report's figure cache (grader.render.figure_cache) holds a figure of every chapter the
    command line names ("all", "ch06", "6"; False where it names none it can tell)."""
    from grader.system import cache_folder

    chapters = set()
    for arg in args[1:] if args and args[0] == "run" else args:
        if arg.startswith("-"):
            break
        if arg == "all":
            chapters |= {f"ch{n:02d}" for n in range(10)}
        elif arg.removeprefix("ch").isdigit() and len(arg.removeprefix("ch")) <= 2:
            chapters.add(f"ch{int(arg.removeprefix('ch')):02d}")
    folder = cache_folder("figures")
    return bool(chapters) and folder is not None and all(
        os.path.isfile(os.path.join(folder, f"{chapter}.json")) for chapter in chapters)


def main() -> None:
    # the imports below (click, the command line's modules, numpy for --html) make tens of thousands of objects and
    # no garbage: the collector stays off until they are done, and then leaves them out of its passes (frozen)
    gc.disable()
    # before anything here imports numpy: the grader's own BLAS threads would only spin beside the child
    os.environ.update(SINGLE_THREADED_BLAS)
    trace("launcher")
    _prestart(sys.argv[1:])
    # matplotlib's import, the report's longest step, starts next on a first run (in the drawing process, forked
    # once numpy is imported here); where figures are kept, the command decides once it knows whether any has to
    # be drawn (grader.faces.cli)
    if _draws_figures(sys.argv[1:]) and not _figures_kept(sys.argv[1:]):
        from grader.render import drawer

        drawer.start()
    from grader.faces.cli import main as cli_main

    gc.freeze()
    gc.enable()
    trace("click and the command line's module imported")

    code: int | str | None = 0
    try:
        cli_main()
    except SystemExit as exc:
        code = exc.code
    finally:
        from grader.faces import prestart

        prestart.take("", None)  # stops a prestarted child nobody took
        if "grader.render.drawer" in sys.modules:  # its drawing process: stopped if unused, else waited for
            sys.modules["grader.render.drawer"].end()  # (no atexit handler runs after os._exit)
        if "grader.course.workers" in sys.modules:  # the folder a batch's coordinator staged learners in
            sys.modules["grader.course.workers"].drop_scratch()
    # Leave without the interpreter's teardown of every imported module (numpy's is slow):
    # everything is written and every child is stopped by now.
    if isinstance(code, str):
        print(code, file=sys.stderr)
        code = 1
    trace("done")
    for what, at in traced():
        print(f"trace {at:8.1f} ms  {what}", file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    if "grader.core.warm_judge" in sys.modules:  # everything written: a judge kept warm for the next command
        sys.modules["grader.core.warm_judge"].linger()
    os._exit(code or 0)
