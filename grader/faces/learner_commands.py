"""The learner's commands of `grade`: run (`grade ch06`, --watch, --html), list, quiz, submit and classroom."""

from __future__ import annotations

import os
import sys

import click

from grader.chapters import CHAPTERS
from grader.faces import prestart
from grader.faces.options import (
    EXIT_USAGE,
    chapter_and_submission_options,
    chapters_and_functions,
    chapters_from,
    emit,
    find_submission,
    renderer_for,
    report_text,
    seed_here,
    unicode_ok,
    use_colour,
)
from grader.files import write_atomically
from grader.render import plural
from grader.submission import Submission
from grader.system import trace


class _RunContext(click.Context):
    """`grade ch06` runs the `run` command without its name: usage lines say `grade`, as the learner typed it."""

    @property
    def command_path(self) -> str:
        return self.parent.command_path if self.parent is not None else super().command_path


class _RunCommand(click.Command):
    context_class = _RunContext


@click.command("run", cls=_RunCommand)
@chapter_and_submission_options
@click.option("--seed", type=int, default=None,
              help="Seed for the random test inputs (default: the public seed; a handout grades only at it).")
@click.option("-v", "--verbose", is_flag=True, help="Show tracebacks and what your code printed.")
@click.option("--learner", default=None, help="Learner id for per-learner quiz numbers "
              "(default: exercises/answers/learner.yaml, else 'anonymous').")
@click.option("--no-quiz", is_flag=True, help="Grade the code only.")
@click.option("--no-sandbox", is_flag=True, help="Do not run your code inside bubblewrap even where it is installed.")
@click.option("--html", "html_path", type=click.Path(dir_okay=False, writable=True), default=None,
              help="Also write a self-contained HTML report with plots made from your functions.")
@click.option("--watch", is_flag=True, help="Stay running: grade again each time a chapter's file is saved, and "
              "say which checks newly pass or fail (Ctrl-C ends it).")
def run_command(chapters: tuple[str, ...], submission_dir: str | None, use_solutions: bool,
                output_format: str, seed: int | None, verbose: bool, learner: str | None,
                no_quiz: bool, no_sandbox: bool, html_path: str | None, watch: bool) -> None:
    """Grade CHAPTER... (ch06, 6 or all): code checks and quiz, each with its points, and a total.
    `grade ch06 H_jacobian` grades that function's checks only (FUNCTION... after the chapter)."""
    picked, functions = chapters_and_functions(chapters)
    no_quiz = no_quiz or bool(functions)
    seed = seed_here(seed)
    submission = find_submission(submission_dir, use_solutions)
    if watch:
        _watch(submission, [c.id for c in picked], seed, learner, no_quiz, no_sandbox, verbose, functions)
        return
    # the child may already run (grader.faces.launch); else it starts now, to overlap our imports below
    from grader.boundary import SandboxMode
    from grader.core import memo
    from grader.core.pipeline import Request
    from grader.core.transaction import Door, grade_submission

    mode = SandboxMode.OFF if no_sandbox else SandboxMode.AUTO
    door = Door(mode, remember=True)
    door.started = prestart.take(mode.value, _chosen(door))
    kept: dict = {}

    def prepare(session) -> None:
        """Once the child runs: the kept verdicts, the drawing process where figures will be drawn, imports."""
        kept["memo"] = memo.default(session.walled)
        if html_path is not None and _figures_likely_drawn(session, [c.id for c in picked], kept["memo"]):
            from grader.render import drawer

            # before any thread (grader.faces.launch may have started it already). The quiz is judged while the
            # child runs the calls (grader.core.pipeline); without a drawing process, matplotlib is imported in a
            # thread, which makes progress while grading waits on the child.
            if not drawer.start():
                import threading

                from grader.render.figures import preload

                threading.Thread(target=preload, daemon=True).start()
        session.meanwhile.append(lambda: renderer_for(output_format))  # its imports, while the child runs the calls

    request = Request(tuple(c.id for c in picked), seed, learner=learner, quiz=not no_quiz,
                      plots=html_path is not None, functions=functions)
    graded = grade_submission(submission, request, door, prepare=prepare, memo=lambda session: kept.pop("memo", None))
    report = graded.report
    trace("judged")
    shown: list[str] = []
    if html_path is not None:
        from grader.render import figure_cache, html

        def show_meanwhile() -> None:  # the terminal's text, made while the figures are drawn
            try:
                shown.append(report_text(report, output_format, verbose))
            except Exception:  # noqa: BLE001  made again by emit, which meets what it raises
                pass

        write_atomically(html_path, html.render(report, figure_cache.default(), meanwhile=show_meanwhile))
        click.echo(f"Wrote the HTML report: {os.path.abspath(html_path)}", err=True)
    emit(report, output_format, verbose, graded.isolation, shown=shown[0] if shown else None)


def _chosen(door):
    """`door`'s boundary; where learner code cannot start here as asked (as root, none without a barrier), the
    command ends with the reason (exit status 2), nothing graded."""
    from grader.boundary import BoundaryUnavailable
    from grader.safe_text import for_terminal

    try:
        return door.boundary
    except BoundaryUnavailable as exc:
        click.echo(f"grade: nothing was graded: {for_terminal(str(exc))}", err=True)
        sys.exit(EXIT_USAGE)


def _figures_likely_drawn(session, chapters: list[str], verdicts) -> bool:
    """Whether the HTML report will most likely draw a figure: unless every chapter's files are those a kept verdict
    was made from (so its plot data are too) and the figure cache holds a figure of each (then matplotlib is not
    imported, nor a drawing process started; a figure that has to be drawn after all is drawn when due)."""
    from grader.render import figure_cache

    folder = figure_cache.default_folder()
    if verdicts is None or folder is None:
        return True
    from grader.core.memo import key_of

    files = key_of(session.prepared.files)
    return not all(verdicts.seen(c, files) and (folder / f"{c}.json").is_file() for c in chapters)


def _watch(submission: Submission, chapters: list[str], seed: int, learner: str | None, no_quiz: bool,
           no_sandbox: bool, verbose: bool, functions: tuple[str, ...] = ()) -> None:
    """`--watch`: a resident fork server (where the system has one) grades each saved chapter again
    (grader.faces.watch)."""
    import time

    from grader.boundary import SandboxMode
    from grader.core.pipeline import Request
    from grader.core.transaction import Door
    from grader.faces import watch
    from grader.render import text

    prestart.take("", None)  # stops a child grader.faces.launch started: the watch's come from its own door
    door = Door(SandboxMode.OFF if no_sandbox else SandboxMode.AUTO, resident=True)
    _chosen(door)
    watcher = watch.Watcher(submission, chapters, Request(tuple(chapters), seed, learner=learner, quiz=not no_quiz,
                                                          functions=functions), door)
    stream = sys.stdout

    def show(report, changes: list[str], seconds: float, saved: list[str]) -> None:
        why = f" after saving {', '.join(saved)}" if saved else ""
        click.echo(f"--- {time.strftime('%H:%M:%S')}: graded {', '.join(c.chapter for c in report.chapters)} in "
                   f"{seconds * 1000:.0f} ms{why}")
        click.echo(text.render(report, colour=use_colour(stream), unicode_ok=unicode_ok(stream), verbose=verbose),
                   nl=False, color=use_colour(stream))
        for line in changes:
            click.echo(line)
        click.echo("(watching for saves; Ctrl-C to stop)")

    try:
        watch.run(watcher, show)
    finally:
        door.close()


@click.command("list")
@click.option("--checks", "show_checks", is_flag=True, help="Also every check's id, points and what it checks.")
def list_command(show_checks: bool) -> None:
    """List the chapters, their functions and points."""
    from grader import checks, course_config
    from grader.core.pipeline import hidden_ids, switched_off

    the_course = course_config.here()
    for info in CHAPTERS:
        chapter = checks.load(info.id)
        hidden, off = hidden_ids(the_course, (info.id,)), switched_off(the_course, (info.id,))
        here = [c for c in chapter.checks if f"{info.id}/{c.id}" not in hidden | off]
        total = sum(c.points for c in here)
        extra = (f" + {sum(c.points for c in chapter.checks if f'{info.id}/{c.id}' in hidden):g} in hidden checks"
                 if hidden else "")
        click.echo(f"{info.id}  {info.title}  ({plural(total, 'point')}{extra})  exercises/{info.module}.py")
        functions: dict[str, float] = {}
        for check in here:
            functions[check.function] = functions.get(check.function, 0) + check.points
        for function, points in functions.items():
            click.echo(f"    {function:<28} {plural(points, 'point')}")
            if show_checks:
                for check in (c for c in here if c.function == function):
                    click.echo(f"        {check.id:<44} {check.points:g}  {check.description}")


@click.command("quiz")
@chapter_and_submission_options
@click.option("--learner", default=None, help="Learner id for per-learner quiz numbers.")
@click.option("--show", is_flag=True, help="Print the questions (with this learner's numbers) instead of grading.")
def quiz_command(chapters: tuple[str, ...], submission_dir: str | None, use_solutions: bool,
                 output_format: str, learner: str | None, show: bool) -> None:
    """Grade only the quiz of CHAPTER... (answers in exercises/answers/chNN.yaml)."""
    picked = chapters_from(chapters)
    submission = find_submission(submission_dir, use_solutions)
    from grader.quiz import quiz_report

    if show:
        from grader.quiz.templates import show_text

        click.echo(show_text([c.id for c in picked], submission.root, submission.package, learner), nl=False)
        return
    report, _ = quiz_report([c.id for c in picked], submission.root, submission.package,
                            str(submission.root), learner)
    from grader import course_config, provenance
    from grader.core.pipeline import practice
    from grader.quiz import answers_dir, learner_id

    the_course = course_config.here()
    for chapter in report.chapters:
        if the_course.practice(chapter.chapter):
            practice(chapter)
    provenance.stamp(report, the_course, learner_id(answers_dir(submission.root, submission.package), learner)[0])
    emit(report, output_format, verbose=False)


@click.command("submit")
@click.option("--learner", default=None, help="Your learner id, as your course lists you (default: "
              "exercises/answers/learner.yaml). It must agree with learner.yaml.")
@click.option("--submission", "submission_dir", type=click.Path(file_okay=False), default=None,
              help="Folder holding exercises/ (default: the project around the current directory).")
@click.option("--out", "out_file", type=click.Path(dir_okay=False), default=None,
              help="Where to write the archive (default: <learner id>.zip beside exercises/).")
def submit_command(learner: str | None, submission_dir: str | None, out_file: str | None) -> None:
    """Pack your exercises/ into the archive your course grades (exactly what grade batch, the Gradescope
    autograder and the GitHub Classroom workflow read), grade that archive again in a fresh process,
    print its score and write a manifest into it (handout, course, file hashes, that score, the time).
    It will not pack without your learner id: your quiz numbers are drawn from it."""
    from pathlib import Path

    from grader.course import submit
    from grader.ids import id_problem
    from grader.quiz import answers_dir, learner_in_file
    from grader.render import text
    from grader.safe_text import for_terminal

    submission = find_submission(submission_dir, False)
    answers = answers_dir(submission.root, submission.package)
    in_file, unusable = learner_in_file(answers, submission.package)  # as grade quiz reads it
    given = learner.strip() if learner else None
    terminal = sys.stdin.isatty() and sys.stdout.isatty()
    if given and in_file and given != in_file:
        if not terminal:
            raise click.UsageError(f"learner.yaml names {in_file!r} but --learner gives {given!r}: your quiz numbers "
                                   "and option letters come from the id, so make them agree (edit "
                                   f"{submission.package}/answers/learner.yaml) and submit again")
        if not click.confirm(f"learner.yaml names {in_file!r}, you gave {given!r}. Your quiz answers must be worked "
                             f"out with your own id's numbers. Use {given!r} and write it into learner.yaml?"):
            raise click.Abort()
    chosen = given or in_file
    if chosen is None:
        why = for_terminal(unusable) if unusable else f"{submission.package}/answers/learner.yaml names nobody"
        if not terminal:
            raise click.UsageError(f"no learner id: {why}, so your quiz was graded with the numbers of 'anonymous'. "
                                   "Put `learner: your-id` in it (as your course lists you), run `grade quiz chNN "
                                   "--show` to see your own numbers, and submit again (or pass --learner your-id)")
        click.echo(f"No learner id: {why}.")
        chosen = click.prompt("Your learner id, as your course lists you (your quiz numbers are drawn from it)",
                              value_proc=_learner_id_typed)
    problem = id_problem(chosen)
    if problem:  # the one rule for ids, as grade batch and learner.yaml have it
        raise click.BadParameter(f"the learner id {chosen!r} {problem}", param_hint="--learner")
    if chosen != in_file:
        submit.write_learner_yaml(answers, chosen)
        click.echo(f"Wrote `learner: {chosen}` into {submission.package}/answers/learner.yaml.")
        if in_file is None:
            click.echo("Your quiz numbers and option letters were those of 'anonymous' until now: check your answers "
                       "with `grade quiz chNN --show` before you hand this archive in.")
    out = Path(out_file) if out_file else Path(submission.root) / f"{chosen}.zip"
    click.echo(f"Packing {submission.package}/ for {chosen} and grading the archive in a fresh process...")
    try:
        manifest = submit.pack(Path(submission.root) / submission.package, chosen, out)
    except submit.SubmitError as exc:
        raise click.ClickException(for_terminal(str(exc))) from None
    local = manifest["local"]
    click.echo("The archive, graded again: " + text.total_line("", local["score"], local["max_score"],
                                                               local["hidden_checks"], local["hidden_points"],
                                                               local["pending_score"] - local["hidden_points"]))
    click.echo(f"Wrote {out} ({len(manifest['files'])} files, manifest {submit.MANIFEST}; handout "
               f"{manifest['handout'] or 'none'}). Hand in this file, as it is.")


def _learner_id_typed(typed: str) -> str:
    """A learner id typed at grade submit's prompt, or the reason it is not one (click asks again)."""
    from grader.ids import id_problem

    chosen = typed.strip()
    problem = id_problem(chosen)
    if problem:
        raise click.UsageError(f"the learner id {chosen!r} {problem}; type it as your course lists you")
    return chosen


@click.command("classroom")
@click.argument("chapters", nargs=-1, metavar="CHAPTER...")
@click.option("--submission", "submission_dir", type=click.Path(file_okay=False), default=None,
              help="Folder holding exercises/ (default: the project around the current directory).")
@click.option("--solutions", "use_solutions", is_flag=True, help="Grade the reference solutions instead.")
@click.option("--learner", default=None, help="Learner id for per-learner quiz numbers.")
@click.option("--output", "output_file", type=click.Path(dir_okay=False, writable=True), default=None,
              help="Write the results JSON to this file instead of standard output.")
@click.option("--github-output", "github_output", type=click.Path(dir_okay=False), default=None,
              help="Also append `result=<the results, base64>` to this file (a step's $GITHUB_OUTPUT).")
@click.option("--sandbox", type=click.Choice(["auto", "required", "off"]), default="auto", show_default=True,
              help="auto: bubblewrap where it starts here, else grade without it and say so; required: exit 2 "
                   "without it.")
def classroom_command(chapters: tuple[str, ...], submission_dir: str | None, use_solutions: bool,
                      learner: str | None, output_file: str | None, github_output: str | None, sandbox: str) -> None:
    """Grade CHAPTER... for GitHub Classroom: every judged check with its own points, in the format its
    autograding reporter reads (the text report goes to standard error). Exits 0 whenever the results
    are written, whatever they say: the reporter gives the points."""
    from grader.course import classroom
    from grader.render import lms, text

    picked = chapters_from(chapters)
    submission = find_submission(submission_dir, use_solutions)
    seed = seed_here(None)
    from grader.boundary import BoundaryUnavailable

    try:
        door, isolation, reason = classroom.sandbox_for(sandbox)
    except BoundaryUnavailable as exc:
        raise click.UsageError(f"the sandbox is required and does not start here: {exc}") from None
    from grader.core.pipeline import Request
    from grader.core.transaction import grade_submission

    report = grade_submission(submission, Request(tuple(c.id for c in picked), seed, learner=learner), door).report
    stream = sys.stderr
    click.echo(text.render(report, colour=use_colour(stream), unicode_ok=unicode_ok(stream), verbose=False),
               nl=False, err=True, color=use_colour(stream))
    click.echo(isolation, err=True)
    results = lms.classroom(report, message=isolation if reason else "")
    if output_file:
        write_atomically(output_file, results)
    else:
        click.echo(results, nl=False)
    if github_output:
        with open(github_output, "a", encoding="utf-8") as handle:
            handle.write(classroom.github_output_line(results))
