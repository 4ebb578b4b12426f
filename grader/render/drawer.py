"""The HTML report's figures (and a batch's class summary's), drawn in processes of their own.

Drawing (matplotlib) is most of the report's cost, and importing matplotlib alone takes about 0.4 s.
So where forking is safe, `grade ... --html` calls `start` before it grades: the drawing process it
forks (with numpy already imported) imports matplotlib and forks its own two drawing processes on the other
core while the grader grades (at a lower priority: the grading is what the figures wait for), then draws the
chapters it is sent. Without it (not started, or it failed) two processes are forked when the figures are
due; where forking is not safe (Windows, macOS) the figures are drawn in the grader's own process. A drawing
process with nothing to draw (every figure reused, see grader.render.figure_cache, or the command ended early)
is stopped; one that sent its figures is waited for when the command ends (`end`). `grade batch` starts one
too: it draws the class summary's figures at the batch's end (`drawn_by_started`). This module imports nothing
heavy until `start`."""

from __future__ import annotations

import os
import signal

from grader.system import forkable_now, keep_only

_STARTED: list = []  # the drawing process and our end of its pipe, until they are used
_ENDING: list = []  # drawing processes that sent their figures and are ending on their own (waited for by `end`)


def start() -> bool:
    """Fork the drawing process now, with numpy imported: matplotlib needs it there, and the grader needs it
    here (to plan and judge the calls whose results the figures show), so it is imported once for both, not in
    each (about 0.1 s of CPU on two busy cores). Call it before any thread starts (a fork copies only the
    calling thread), and after the learner's child is started (numpy's import would delay it). False where
    forking is not safe here now (grader.system.forkable_now) or fails."""
    from grader.system import keep, trace

    if _STARTED or not forkable_now():
        return bool(_STARTED)
    import multiprocessing

    import numpy  # noqa: F401

    context = multiprocessing.get_context("fork")
    ours, theirs = context.Pipe()
    process = context.Process(target=_draw_what_comes, args=(theirs,), name="grade-report-drawer")
    try:
        process.start()
    except OSError:
        return False
    theirs.close()
    keep(process.pid)  # the grader's own process: the boundary's clean-up of orphans leaves it alone
    trace("drawing process started")
    _STARTED.append((process, ours))
    import atexit

    atexit.register(end)  # before multiprocessing's own exit handler, which would wait for it
    return True


def end() -> None:
    """End the drawing process: stopped if nothing was sent to it, rather than let it import matplotlib for
    nobody (at once while it imports, else as soon as its drawing processes have ended, see _draw_what_comes);
    waited for if it sent its figures (it ends on its own once its drawing processes have)."""
    while _STARTED:
        process, ours = _STARTED.pop()
        ours.close()
        process.terminate()
        _ended(process)
    while _ENDING:
        _ended(_ENDING.pop())


def _ended(process) -> None:
    """Wait for the drawing process to end (killed if it does not), and forget it: its pid may be reused."""
    from grader.system import forget

    process.join(5)
    if process.is_alive():
        process.kill()
        process.join()
    forget(process.pid)


def _draw_what_comes(connection) -> None:
    """The drawing process: only its pipe stays open (no copy of the grader's pipes to the learner's
    child, nor of its output: a pipeline `grade ... | less` ends with the grader); it ends when the pipe
    closes."""
    import gc

    from grader.render.figures import preload

    # Background work: matplotlib's import runs while the grader and the learner's child grade, on the same cores,
    # and the grading is what the figures wait for (first run -3% wall, paired). Its drawing processes inherit it.
    os.nice(10)
    keep_only(connection.fileno())
    try:
        # matplotlib's import makes some 40,000 objects the collector tracks, and no garbage: its passes over them
        # were 7% of this process's work. Frozen, they stay out of the drawing processes' collections too (and out of
        # their copies of pages). No figure is drawn here first: one nobody sees cost more than it saved them.
        gc.disable()
        try:
            preload()
        finally:
            gc.freeze()
            gc.enable()
        # Until here SIGTERM (`end`) ends this process at once. From here it waits (blocked): ending now
        # would leave the drawing processes waiting for work forever, while the pipe's end (EOF) ends them
        # and this process in order.
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
        with two_processes() as pool:
            list(pool.map(int, range(2)))  # both drawing processes forked now, not when the figures are due
            connection.send(_draw_with(pool, *connection.recv()))
    except Exception:  # noqa: BLE001  the grader ended (EOF), or draws the figures itself as we send none
        return


def _take_sigterm() -> None:
    """A drawing process dies of SIGTERM as usual (the process that forked it may have blocked it)."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})


def _draw_with(pool, draw: tuple[str, str], items: list, order: list[int]) -> list:
    """`draw` (a module and the name of its function, found here: this process's own) of each of `items`, in
    their order, drawn by `pool`'s processes and started in `order` (the longest first)."""
    import importlib

    function = getattr(importlib.import_module(draw[0]), draw[1])
    futures = {i: pool.submit(function, items[i]) for i in order}
    return [futures[i].result() for i in range(len(items))]


def _chapters_job(chapters: list) -> tuple:
    """What the drawing processes get to draw each chapter's figures (grader.render.figures.figures): the
    two-panel figures first (they take longest)."""
    from grader.render.figures import TWO_PANELS

    return (("grader.render.figures", "figures"), chapters,
            sorted(range(len(chapters)), key=lambda i: chapters[i].chapter not in TWO_PANELS))


def drawn_by_started(draw: tuple[str, str], items: list) -> list | None:
    """`draw` (a module and the name of its function) of each of `items`, in their order, by the started drawing
    process (matplotlib imported there while this process worked, its two drawing processes waiting): None where
    none was started or it failed, for the caller to draw them itself."""
    sent = _send((draw, items, list(range(len(items)))))
    return None if sent is None else _received(sent)


def _send(job: tuple):
    """`job` sent to the started drawing process: (the process, our end of its pipe), or None where none was
    started, or it died, or the job would not pickle (then it is stopped)."""
    if not _STARTED:
        return None
    process, ours = _STARTED.pop()
    try:
        ours.send(job)
    except Exception:  # noqa: BLE001  it died, or the job would not pickle: drawn elsewhere instead
        _STARTED.append((process, ours))
        end()
        return None
    return process, ours


def _received(sent: tuple) -> list | None:
    """What the drawing process `sent` a job to drew; None where it died first. It ends once its drawing processes
    have (10 to 30 ms): waited for by `end` when the command ends, not before its output is written."""
    process, ours = sent
    try:
        drawn = ours.recv()
    except (EOFError, OSError):
        ours.close()
        _ended(process)
        return None
    ours.close()
    _ENDING.append(process)
    return drawn


def two_processes():
    """Two forked drawing processes (one where there is one core); fork them only where forkable_now says so."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(max_workers=min(2, os.cpu_count() or 1), mp_context=multiprocessing.get_context("fork"),
                               initializer=_take_sigterm)


def _draw_in_two(chapters: list) -> list[list]:
    from grader.system import trace

    trace("drawing processes forked when the figures were due")
    with two_processes() as pool:
        return _draw_with(pool, *_chapters_job(chapters))


def figures_due(chapters: list, here: bool = False):
    """Start drawing the figures of `chapters` (grader.model.ChapterResult); returns the function that
    waits for them, one list of figures per chapter: drawn by the started drawing process, else by two
    processes forked then, where forkable_now says so, else by this process. With no chapters, the started
    drawing process is stopped. `here`: drawn by this process in any case (a batch worker, one of as many
    as there are cores: forking more for each learner only costs forks)."""
    from grader.render.figures import figures, preload

    def drawn_here() -> list[list]:
        return [figures(chapter) for chapter in chapters]

    if here:
        return drawn_here
    if not chapters:
        end()
    sent = _send(_chapters_job(chapters)) if chapters else None

    def wait() -> list[list]:
        drawn = None if sent is None else _received(sent)
        if drawn is not None:
            return drawn
        if len(chapters) > 1:
            try:
                preload()  # here, before any fork (a thread still importing it keeps the figures here: forkable_now)
                if forkable_now():
                    return _draw_in_two(chapters)
            except (OSError, ValueError, ImportError, RuntimeError):
                pass
        return drawn_here()

    return wait
