"""The resident grading process behind `%grade` (grader.faces.magic): a process of its own beside the IPython
kernel, so that the kernel imports nothing of the grader but a small client and never runs a check.

It reads one JSON request per line on stdin (the `%grade` arguments, the kernel's working folder, the
names of functions the notebook itself defined and the cells the kernel ran) and answers one JSON line
on its real stdout: the report as text, as an HTML fragment (grader.render.html.render_fragment, with
plots) where the front end shows HTML, and the score. Learner code runs only in the sandboxed children of
its resident door (grader.core.transaction, resident: a fork server where the system allows, else a fresh
child per run), graded by the one transaction as under `grade chNN`; the checks and references stay imported here between runs, so
a second `%grade` costs the run itself. It ends when the kernel closes its stdin.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path


class Server:
    """One kernel's grading process: its doors (one per sandbox setting, kept between runs) and requests."""

    def __init__(self) -> None:
        self.doors: dict[bool, object] = {}

    def door(self, sandboxed: bool):
        """Where a run's children come from: the resident grader.core.transaction.Door for this sandbox setting."""
        if sandboxed not in self.doors:
            from grader.boundary import SandboxMode
            from grader.core.transaction import Door

            self.doors[sandboxed] = Door(SandboxMode.AUTO if sandboxed else SandboxMode.OFF, resident=True)
        return self.doors[sandboxed]

    def warm_up(self) -> None:
        """Import what grading needs and start the fork server, before the first `%grade` asks."""
        from grader import checks
        from grader.chapters import CHAPTERS

        for info in CHAPTERS:
            checks.load(info.id)
        import grader.core.pipeline  # noqa: F401
        import grader.render.text  # noqa: F401

        self.door(True).boundary.warm_up()

    def close(self) -> None:
        for door in self.doors.values():
            door.close()

    def handle(self, request: dict) -> dict:
        """Grade as `grade run` would with request["args"]; {"error": why} for arguments it cannot take."""
        import click

        from grader.faces.learner_commands import run_command

        os.chdir(request.get("cwd") or ".")
        args = [str(a) for a in request.get("args", [])]
        if any(a in ("-h", "--help") for a in args):
            with run_command.make_context("%grade", ["x"]) as ctx:
                return {"text": run_command.get_help(ctx)}
        try:
            ctx = run_command.make_context("%grade", args)
            return self._grade(ctx.params, request)
        except click.ClickException as exc:
            return {"error": exc.format_message()}

    def _grade(self, options: dict, request: dict) -> dict:
        import click

        from grader.core.pipeline import Request
        from grader.core.transaction import grade_submission
        from grader.faces.options import chapters_and_functions, seed_here
        from grader.render import text

        if options["watch"]:
            raise click.UsageError("%grade has no --watch: run the cell again after an edit (it stays fast)")
        defined = set(request.get("defined", []))
        names = options["chapters"] or tuple(_chapters_defining(defined))
        if not names:
            raise click.UsageError("name a chapter: %grade ch06 (or %grade all; %grade ch06 H_jacobian for one "
                                   "function)")
        picked, functions = chapters_and_functions(names)
        seed = seed_here(options["seed"])
        submission = self._submission(options, [c.id for c in picked], defined, request.get("cells", []))
        html = bool(request.get("html"))
        request = Request(tuple(c.id for c in picked), seed, learner=options["learner"],
                          quiz=not options["no_quiz"] and not functions, plots=html or options["html_path"] is not None,
                          functions=functions)
        report = grade_submission(submission, request, self.door(not options["no_sandbox"])).report
        for chapter in report.chapters:
            note = _unsaved(submission, chapter.chapter)
            if note:
                chapter.notes.append(note)
        if options["html_path"] is not None:
            from grader.files import write_atomically
            from grader.render import figure_cache
            from grader.render import html as page

            write_atomically(options["html_path"], page.render(report, figure_cache.default()))
        if options["output_format"] == "json":
            from grader.render import json_report

            return {"text": json_report.render(report), "html": "", "score": report.score,
                    "max_score": report.max_score, "all_passed": report.all_passed}
        fragment = ""
        if html:
            from grader.render import figure_cache
            from grader.render.html import render_fragment

            fragment = render_fragment(report, kept=figure_cache.default())
        return {"text": text.render(report, colour=False, unicode_ok=True, verbose=options["verbose"]),
                "html": fragment, "score": report.score, "max_score": report.max_score,
                "all_passed": report.all_passed}

    def _submission(self, options: dict, chapters: list[str], defined: set[str], cells: list):
        """What to grade: --solutions or --submission as given; else the project around the kernel's folder
        (or the chapter files in it), with each chapter whose functions the notebook defined itself graded
        from the cells the kernel ran, in order."""
        import click

        from grader.chapters import BY_ID
        from grader.submission import (
            Submission,
            SubmissionNotFound,
            folder_submission,
            locate,
        )

        if options["use_solutions"] or options["submission_dir"] is not None:
            return cli_submission(options)
        from_kernel = [c for c in chapters if _functions(c) & defined]
        try:
            submission = locate(None, False)
        except SubmissionNotFound:
            try:
                submission = folder_submission(Path.cwd())
            except SubmissionNotFound:
                if not from_kernel:
                    raise click.UsageError(
                        f"this notebook defines none of the functions of {', '.join(chapters)} and there is no "
                        "exercises/ folder here or above: run the cells that define them first, or work in the "
                        "lesson's project") from None
                submission = Submission(_empty_root(), "exercises")
        if not from_kernel:
            return submission
        history = tuple((str(label), str(code)) for label, code in cells)
        return submission._replace(kernel=tuple((BY_ID[c].module, history) for c in from_kernel))


def _definitions(cells: list[str]) -> dict[str, str]:
    """Each top-level function the cells define, run in order, the last definition of a name winning, as its syntax
    tree's dump (so that spacing, comments and line endings do not count). Each cell is read as the module made of
    cells reads it (grader.notebook.python_lines: IPython's own lines left out); one that does not compile defines
    nothing, as it did nothing in the kernel."""
    import ast

    from grader.notebook import python_lines

    found: dict[str, str] = {}
    for code in cells:
        try:
            tree = ast.parse("\n".join(python_lines(code)) + "\n")
        except (SyntaxError, ValueError, RecursionError, MemoryError):
            continue
        found.update((node.name, ast.dump(node)) for node in tree.body
                     if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)))
    return found


def _unsaved(submission, chapter: str) -> str:
    """Where `chapter` was graded from the cells the kernel ran and its saved file exists: a note naming the
    functions whose code there differs from the kernel's (`grade chNN` and `grade submit` grade the saved file),
    else "". Both sides are read alike: a saved notebook cell by cell, as the kernel's cells are, a .py as Python
    reads it."""
    from grader.chapters import BY_ID
    from grader.notebook import NotebookError, code_cells
    from grader.safe_text import decode_saved_text

    module = BY_ID[chapter].module
    cells = dict(submission.kernel).get(module)
    saved = submission.chapter_file(module)
    if cells is None or not saved.is_file():
        return ""
    kernel = _definitions([code for _, code in cells])
    try:
        data = saved.read_bytes()
        texts = ([source for _, source in code_cells(data)] if saved.suffix == ".ipynb"
                 else [decode_saved_text(data)[0]])
    except (OSError, NotebookError):
        return ""
    on_disk = _definitions(texts)
    differ = sorted(name for name in _functions(chapter) if kernel.get(name) != on_disk.get(name)
                    and name in kernel)
    if not differ:
        return ""
    return (f"graded the code this notebook's kernel ran; the saved {saved.name} has other code for "
            f"{', '.join(differ)}: `grade {chapter}` and `grade submit` grade the saved file, so save the notebook "
            "before you submit")


def cli_submission(options: dict):
    from grader.faces.options import find_submission

    return find_submission(options["submission_dir"], options["use_solutions"])


def _functions(chapter: str) -> set[str]:
    from grader import checks

    return {c.function for c in checks.load(chapter).checks}


def _chapters_defining(defined: set[str]) -> list[str]:
    from grader.chapters import CHAPTERS

    return [c.id for c in CHAPTERS if _functions(c.id) & defined]


_EMPTY: list[Path] = []


def _empty_root() -> Path:
    """A folder with an empty exercises/ for a notebook that is the whole submission (Colab)."""
    if not _EMPTY:
        import atexit
        import shutil
        import tempfile

        root = Path(tempfile.mkdtemp(prefix="grade-notebook-"))
        (root / "exercises").mkdir()
        atexit.register(shutil.rmtree, root, True)
        _EMPTY.append(root)
    return _EMPTY[0]


def main() -> None:
    """Serve requests on stdin until it closes; answers go to the stdout this process started with (what
    the grader itself prints goes to stderr)."""
    answers = os.fdopen(os.dup(1), "w", encoding="utf-8", newline="\n")
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    server = Server()
    try:
        if "--warm" in sys.argv[1:]:
            try:
                server.warm_up()
            except Exception:  # a warm-up that fails leaves the work to the first request
                pass
        for line in sys.stdin:
            try:
                answer = server.handle(json.loads(line))
            except Exception as exc:  # a grader bug: said in the notebook, the process goes on
                import traceback

                answer = {"error": f"the grader failed: {type(exc).__name__}: {exc}\n{traceback.format_exc(limit=-4)}"}
            answers.write(json.dumps(answer) + "\n")
            answers.flush()
    finally:
        server.close()


if __name__ == "__main__":
    main()
