"""The `grade` command: a thin click layer over grader.core.grading and the renderers.

    grade ch06 | grade 6 | grade all       grade code (and quizzes) of chapters
    grade list                             chapters, functions and points
    grade quiz ch06                        only the quiz
    grade classroom all                    GitHub Classroom's per-check results
    grade submit                           pack exercises/ into the archive your course grades
    grade release / batch / worker / gradescope     the instructor's side
"""

from __future__ import annotations

import os
import sys

import click

from grader.chapters import CHAPTERS, ChapterInfo, resolve
from grader.faces import prestart
from grader.render import plural
from grader.submission import Submission, SubmissionNotFound, locate
from grader.system import trace

EXIT_ALL_PASSED, EXIT_NOT_ALL_PASSED, EXIT_USAGE = 0, 1, 2


class _DefaultToRun(click.Group):
    """`grade ch06 ...` means `grade run ch06 ...`: anything that is not a subcommand is a chapter. A word
    that is neither a chapter nor a command but close to a command (`grade lst`) is a usage error that
    names the command."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in self.commands and args[0] not in ("--help", "-h", "--version"):
            if not args[0].startswith("-") and not _is_chapter(args[0]):
                chapter = _chapter_of_file(args[0])
                if chapter is not None:
                    raise click.UsageError(f"{args[0]!r} is a chapter's file; grade it by its chapter: `grade {chapter}` "
                                           "(`grade list` shows the chapters)", ctx)
                import difflib

                close = difflib.get_close_matches(args[0].lower(), [c for c in self.commands if c != "run"], n=1,
                                                  cutoff=0.6)
                if close:
                    raise click.UsageError(f"no command or chapter {args[0]!r}; did you mean `grade {close[0]}`? "
                                           "(`grade --help` lists the commands, `grade list` the chapters)", ctx)
            args = ["run", *args]
        return super().parse_args(ctx, args)


def _chapter_of_file(name: str) -> str | None:
    """The chapter whose file `name` names (exercises/ch06_measurement.py, ch06_measurement.ipynb, ch06_measurement),
    or None."""
    stem = name.replace("\\", "/").rsplit("/", 1)[-1]
    for suffix in (".py", ".ipynb"):
        stem = stem.removesuffix(suffix)
    return next((c.id for c in CHAPTERS if c.module == stem), None)


def _is_chapter(name: str) -> bool:
    if name.lower() == "all":
        return True
    try:
        resolve(name)
    except KeyError:
        return False
    return True


@click.group(cls=_DefaultToRun, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="jacobians-grader")
def main() -> None:
    """Grade the lesson "Jacobians & Linearization": `grade ch06`, `grade all`, `grade list`."""
    _encode_what_the_console_can()


def _encode_what_the_console_can() -> None:
    """A console or redirect in a code page without ✓, σ or a learner's own characters (Windows) shows '?'
    for them instead of ending in UnicodeEncodeError; the text renderer also picks plain marks there."""
    for stream in (sys.stdout, sys.stderr):
        encoding = (getattr(stream, "encoding", None) or "").lower().replace("-", "").replace("_", "")
        if encoding not in ("utf8", "utf8sig") and hasattr(stream, "reconfigure"):
            try:
                stream.reconfigure(errors="replace")
            except (ValueError, OSError):  # a stream already written to in another way
                pass


def chapters_from(names: tuple[str, ...]) -> list[ChapterInfo]:
    """Chapter arguments ('ch06', '6', 'all') to chapters, in lesson order; BadParameter if unknown."""
    if not names:
        raise click.UsageError("name a chapter (ch00-ch09, 0-9) or 'all'; `grade list` shows them")
    if any(n.lower() == "all" for n in names):
        return list(CHAPTERS)
    try:
        picked = {resolve(n).id for n in names}
    except KeyError as exc:
        raise click.BadParameter(exc.args[0], param_hint="CHAPTER") from None
    return [c for c in CHAPTERS if c.id in picked]


def chapters_and_functions(names: tuple[str, ...]) -> tuple[list[ChapterInfo], tuple[str, ...]]:
    """`grade ch06 H_jacobian`: the chapters named, and the functions whose checks alone are graded (a
    function alone names its chapter: `grade H_jacobian`). BadParameter for a name that is neither."""
    import re

    chapter_like = [n for n in names if _is_chapter(n) or re.fullmatch(r"(ch)?\d+", n.strip(), re.I)]
    functions = tuple(dict.fromkeys(n for n in names if n not in chapter_like))
    picked = chapters_from(tuple(chapter_like)) if chapter_like else []
    if not functions:
        return picked, ()
    from grader import checks

    owners: dict[str, str] = {}
    for info in CHAPTERS:
        for check in checks.load(info.id).checks:
            owners.setdefault(check.function, info.id)
    for function in functions:
        if function not in owners:
            import difflib

            close = difflib.get_close_matches(function, list(owners), n=1)
            hint = f"; did you mean {close[0]}?" if close else ""
            raise click.BadParameter(f"{function!r} is neither a chapter nor a function of one{hint} (`grade list` "
                                     "names every chapter's functions)", param_hint="CHAPTER... [FUNCTION...]")
        if picked and owners[function] not in {c.id for c in picked}:
            raise click.BadParameter(f"{function} is a function of {owners[function]}, not of "
                                     f"{', '.join(c.id for c in picked)}", param_hint="CHAPTER... [FUNCTION...]")
    if not picked:
        picked = [c for c in CHAPTERS if c.id in {owners[f] for f in functions}]
    return picked, functions


def find_submission(directory: str | None, use_solutions: bool) -> Submission:
    """The submission to grade: --solutions, --submission DIR, or the project around the cwd."""
    try:
        return locate(directory, use_solutions)
    except SubmissionNotFound as exc:
        if directory is not None:
            raise click.BadParameter(str(exc), param_hint="--submission") from None
        raise click.UsageError(str(exc)) from None


def _use_colour(stream) -> bool:
    """Colour on a terminal. NO_COLOR (no-color.org) and FORCE_COLOR (force-color.org) count when set to
    something other than the empty string; NO_COLOR wins over FORCE_COLOR, as in Python itself."""
    if os.environ.get("NO_COLOR", ""):
        return False
    if os.environ.get("FORCE_COLOR", ""):
        return True
    return hasattr(stream, "isatty") and stream.isatty()


def _unicode_ok(stream) -> bool:
    try:
        "✓✗".encode(getattr(stream, "encoding", None) or "ascii")
        return True
    except (UnicodeEncodeError, LookupError):
        return False


def chapter_and_submission_options(command):
    """CHAPTER..., --submission, --solutions and --format: shared by `grade run` and `grade quiz`."""
    for option in reversed([
        click.argument("chapters", nargs=-1, metavar="CHAPTER..."),
        click.option("--submission", "submission_dir", type=click.Path(file_okay=False), default=None,
                     help="Folder holding exercises/ (default: the project around the current directory)."),
        click.option("--solutions", "use_solutions", is_flag=True, help="Grade the reference solutions instead."),
        click.option("--format", "output_format", type=click.Choice(["text", "json"]), default="text",
                     show_default=True, help="Output format."),
    ]):
        command = option(command)
    return command


class _RunContext(click.Context):
    """`grade ch06` runs the `run` command without its name: usage lines say `grade`, as the learner typed it."""

    @property
    def command_path(self) -> str:
        return self.parent.command_path if self.parent is not None else super().command_path


class _RunCommand(click.Command):
    context_class = _RunContext


@main.command("run", cls=_RunCommand)
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
    seed = _seed_here(seed)
    submission = find_submission(submission_dir, use_solutions)
    if watch:
        _watch(submission, [c.id for c in picked], seed, learner, no_quiz, no_sandbox, verbose, functions)
        return
    # the child may already run (grader.faces.launch); else start it now, to overlap our imports below
    from grader import boundary
    from grader.core import memo

    sandbox = "off" if no_sandbox else "auto"
    door = boundary.choose(sandbox, remember=True)
    session = door.open_session(submission, started=prestart.take(sandbox, door))
    verdicts = memo.default(session.walled)
    drawing = False
    if html_path is not None and _figures_likely_drawn(session, [c.id for c in picked], verdicts):
        from grader.render import drawer

        drawing = drawer.start()  # before any thread (grader.faces.launch may have started it already)
        # The quiz is judged while the child runs the calls (grader.core.pipeline); without a drawing process,
        # matplotlib is imported in a thread, which makes progress while grading waits on the child.
        if not drawing:
            import threading

            from grader.render.figures import preload

            threading.Thread(target=preload, daemon=True).start()
    from grader.core.pipeline import Request, build_report

    session.meanwhile.append(lambda: _renderer(output_format))  # its imports, while the child runs the calls
    request = Request(tuple(c.id for c in picked), seed, learner=learner, quiz=not no_quiz,
                      plots=html_path is not None, functions=functions)
    try:
        report = build_report(session, request, memo=verdicts)
    finally:
        session.close()
    if report.infrastructure and door.sandboxed:  # the child did not start: never behind a kept sandbox again
        from grader.boundary import kept

        kept.forget()
        door = boundary.choose(sandbox)  # decided afresh, once, and kept nowhere
        session = door.open_session(submission)
        try:
            report = build_report(session, request)
        finally:
            session.close()
    trace("judged")
    shown: list[str] = []
    if html_path is not None:
        from grader.render import figure_cache, html

        def show_meanwhile() -> None:  # the terminal's text, made while the figures are drawn
            try:
                shown.append(_shown(report, output_format, verbose))
            except Exception:  # noqa: BLE001  made again by _emit, which meets what it raises
                pass

        write_atomically(html_path, html.render(report, figure_cache.default(), meanwhile=show_meanwhile))
        click.echo(f"Wrote the HTML report: {os.path.abspath(html_path)}", err=True)
    _emit(report, output_format, verbose, session.isolation, shown=shown[0] if shown else None)


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

    from grader import boundary
    from grader.core.pipeline import Request
    from grader.faces import watch
    from grader.render import text

    prestart.take("", None)  # stops a child grader.faces.launch started: the watch's come from its own boundary
    door = boundary.choose("off" if no_sandbox else "auto", resident=True)
    watcher = watch.Watcher(submission, chapters, Request(tuple(chapters), seed, learner=learner, quiz=not no_quiz,
                                                          functions=functions), door)
    stream = sys.stdout

    def show(report, changes: list[str], seconds: float, saved: list[str]) -> None:
        why = f" after saving {', '.join(saved)}" if saved else ""
        click.echo(f"--- {time.strftime('%H:%M:%S')}: graded {', '.join(c.chapter for c in report.chapters)} in "
                   f"{seconds * 1000:.0f} ms{why}")
        click.echo(text.render(report, colour=_use_colour(stream), unicode_ok=_unicode_ok(stream), verbose=verbose),
                   nl=False, color=_use_colour(stream))
        for line in changes:
            click.echo(line)
        click.echo("(watching for saves; Ctrl-C to stop)")

    try:
        watch.run(watcher, show)
    finally:
        door.close()


def _seed_here(seed: int | None) -> int:
    """The seed to grade at: the public one unless given; a handout has check data for that one only."""
    from grader import course_config

    public = course_config.PUBLIC_SEED
    if seed is None or seed == public:
        return public
    if course_config.in_handout():
        raise click.BadParameter(f"this handout grades at its public seed ({public}) only: its expected "
                                 "values were recorded there; other seeds are used when your submission is graded",
                                 param_hint="--seed")
    return seed


def _instructor_course(config: str | None, command: str):
    """The instructor's course configuration; a usage error in a handout or for a broken file."""
    from grader import course_config

    if course_config.in_handout():
        raise click.UsageError(f"{command} runs on the instructor's side, with the references; this is a learner's "
                               "handout")
    from grader.core.pipeline import instructor_course

    try:
        return instructor_course(config)
    except course_config.CourseError as exc:
        raise click.BadParameter(str(exc), param_hint="--course") from None


def _handout_id(given: str) -> str:
    """--handout: an id as it is, or the folder `grade release` wrote (or its handout.json): the id in it."""
    import json
    from pathlib import Path

    path = Path(given)
    if path.is_dir():
        path = path / "handout.json"
    if not path.is_file():
        return given
    try:
        return str(json.loads(path.read_text(encoding="utf-8"))["version"])
    except (OSError, ValueError, KeyError, TypeError):
        raise click.BadParameter(f"{path} is not the handout.json grade release writes",
                                 param_hint="--handout") from None


def write_atomically(path: str, text: str) -> None:
    """Write `text` to `path` through a temporary file, so a reader never sees half a file."""
    temporary = f"{path}.{os.getpid()}.tmp"
    with open(temporary, "w", encoding="utf-8") as handle:
        handle.write(text)
    os.replace(temporary, path)


def _renderer(output_format: str):
    """The module that prints a report in `output_format` (grader.render.json_report or .text)."""
    if output_format == "json":
        from grader.render import json_report

        return json_report
    from grader.render import text

    return text


def _shown(report, output_format: str, verbose: bool) -> str:
    """The report as the chosen format prints it on stdout."""
    renderer = _renderer(output_format)
    if output_format == "json":
        return renderer.render(report)
    stream = sys.stdout
    return renderer.render(report, colour=_use_colour(stream), unicode_ok=_unicode_ok(stream), verbose=verbose)


def _emit(report, output_format: str, verbose: bool, isolation: str = "", shown: str | None = None) -> None:
    """Print the report in the chosen format (`shown`: as _shown made it already) and exit 0 (all passed) or 1;
    with `verbose`, the isolation line (what held for the learner's code) first, on stderr."""
    if verbose and isolation:
        click.echo(isolation, err=True)
    text = _shown(report, output_format, verbose) if shown is None else shown
    click.echo(text, nl=False, color=None if output_format == "json" else _use_colour(sys.stdout))
    sys.exit(EXIT_ALL_PASSED if report.all_passed else EXIT_NOT_ALL_PASSED)


@main.command("list")
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


@main.command("quiz")
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
    _emit(report, output_format, verbose=False)


@main.command("release")
@click.argument("out", type=click.Path(file_okay=False))
@click.option("--course", "course_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="The course configuration (default: solutions/course.yaml beside the references).")
@click.option("--force", is_flag=True, help="Replace what OUT holds.")
@click.option("--no-classroom", is_flag=True,
              help="Leave out the GitHub Classroom workflow (.github/workflows/classroom.yml).")
@click.option("--notebooks", is_flag=True,
              help="Each chapter's stub as a Jupyter notebook (exercises/chNN_*.ipynb, for Jupyter and Colab) "
                   "instead of a .py: install cell, text as markdown, a cell per function, %grade last.")
@click.option("--pip-source", default=None, metavar="SPEC",
              help="What the notebooks' first cell installs where the grader is missing, e.g. the wheel's URL "
                   "for Colab (default: the wheel beside exercises/).")
def release_command(out: str, course_file: str | None, force: bool, no_classroom: bool, notebooks: bool,
                    pip_source: str | None) -> None:
    """Build the learners' handout in OUT: stubs, answer templates, the grader as a wheel, a README and a
    GitHub Classroom workflow; no reference solution, quiz key or reference answer in any of it."""
    from pathlib import Path

    from grader.course import release

    the_course = _instructor_course(course_file, "grade release")
    try:
        built = release.build(Path(out), the_course, force=force, notebooks=notebooks, pip_source=pip_source)
    except release.OutNotEmpty as exc:
        raise click.BadParameter(str(exc), param_hint="OUT") from None
    except release.ReleaseError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(release.describe(built))
    if not no_classroom:
        from grader.course import classroom

        path = classroom.write_template(Path(out), built.wheel.name)
        click.echo(f"GitHub Classroom: {path} runs `grade classroom all` on every push of a learner's repository "
                   "and reports each check's points (use OUT as the assignment's template repository).")


@main.command("submit")
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
    from grader.quiz import answers_dir, learner_id
    from grader.render import text
    from grader.safe_text import for_terminal

    submission = find_submission(submission_dir, False)
    answers = answers_dir(submission.root, submission.package)
    written, source = learner_id(answers, None, submission.package)
    in_file = None if source.startswith("default") else written
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
        if not terminal:
            raise click.UsageError(f"no learner id: {submission.package}/answers/learner.yaml names nobody, so your "
                                   "quiz was graded with the numbers of 'anonymous'. Put `learner: your-id` in it "
                                   "(as your course lists you), run `grade quiz chNN --show` to see your own numbers, "
                                   "and submit again (or pass --learner your-id)")
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


@main.command("batch")
@click.argument("submissions", type=click.Path(exists=True, file_okay=False))
@click.option("--out", "out_dir", type=click.Path(file_okay=False), required=True, help="Output folder.")
@click.option("--roster", type=click.Path(exists=True, dir_okay=False), default=None,
              help="CSV with columns submission,learner mapping folder/zip names to learner ids (',' or ';').")
@click.option("--chapters", "chapter_list", default="all", show_default=True, help="e.g. ch05,ch06")
@click.option("--jobs", type=click.IntRange(min=1), default=None, help="Parallel workers (default: all cores).")
@click.option("--seed", type=int, default=None,
              help="Seed for the random test inputs (default: the course seed of solutions/course.yaml).")
@click.option("--course", "course_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="The course configuration (default: solutions/course.yaml beside the references).")
@click.option("--no-html", is_flag=True, help="Skip the per-learner report.html.")
@click.option("--plots", is_flag=True, help="Draw plots in each report.html (about 0.5 s of CPU per learner).")
@click.option("--no-sandbox", is_flag=True,
              help="Run learner code without bubblewrap even where it is installed (the isolation line says so).")
@click.option("--time-budget", type=click.FloatRange(min=1), default=60, show_default=True,
              help="Seconds for one learner's code, all chapters together; the quiz gets what is left.")
@click.option("--lms", "lms_layouts", type=click.Choice(["canvas", "moodle"]), multiple=True,
              help="Also write the gradebook as that system imports it: gradebook-canvas.csv, gradebook-moodle.csv "
                   "(repeat for both).")
@click.option("--overrides", "overrides_file", type=click.Path(dir_okay=False), default=None,
              help="Overrides (learner,target,points,factor,reason,who) applied on every run (default: "
                   "OUT/overrides.csv where it exists).")
@click.option("--handout", "handout", default=None,
              help="The current handout: its id, or the folder grade release wrote (its handout.json); archives "
                   "packed with another are flagged (default: the course config's `handout:`).")
@click.option("--similarity", is_flag=True,
              help="Rank pairs of learners by how alike their code is (copydetect), for a person to look at.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Grade on a Dask cluster: its scheduler, e.g. tcp://host:8786, whose workers run `grade worker` "
                   "(default: $DASK_SCHEDULER_ADDRESS, else the course file's `scheduler:`; `local`: this machine's "
                   "pool). Needs the [cluster] extra.")
def batch_command(submissions: str, out_dir: str, roster: str | None, chapter_list: str, jobs: int | None,
                  seed: int | None, course_file: str | None, no_html: bool, plots: bool, no_sandbox: bool,
                  time_budget: float, lms_layouts: tuple[str, ...], overrides_file: str | None, handout: str | None,
                  similarity: bool, scheduler: str | None) -> None:
    """Grade a folder of submissions (folders or .zip files) into a gradebook and per-learner reports,
    at the course seed, hidden checks included; keep every run in OUT/gradebook.db and say in
    OUT/changes.csv whose score moved and why."""
    import dataclasses
    from pathlib import Path

    from grader.course import batch
    from grader.safe_text import for_terminal

    picked = chapters_from(tuple(chapter_list.split(",")))
    the_course = _instructor_course(course_file, "grade batch")
    if handout is not None:
        the_course = dataclasses.replace(the_course, current_handout=_handout_id(handout))
    if similarity:
        from grader.course import similarity as similarities

        try:
            similarities._engine()
        except similarities.SimilarityUnavailable as exc:
            raise click.UsageError(str(exc)) from None
    pool = _cluster_pool(scheduler, the_course, jobs)
    try:
        result = batch.run_batch(Path(submissions), Path(out_dir), chapters=[c.id for c in picked],
                                 roster=Path(roster) if roster else None, jobs=jobs,
                                 seed=the_course.grading_seed if seed is None else seed, html=not no_html,
                                 plots=plots, limits={"learner_seconds": time_budget}, sandboxed=not no_sandbox,
                                 progress=batch.progress_bar(), hidden=the_course.hidden,
                                 lms_layouts=tuple(lms_layouts), course=the_course,
                                 overrides=Path(overrides_file) if overrides_file else None, similarity=similarity,
                                 announce=lambda line: click.echo(line, err=True), pool=pool)
    except batch.RosterError as exc:
        hint = "--overrides" if "overrides" in str(exc) else "--roster"
        raise click.BadParameter(for_terminal(str(exc)), param_hint=hint) from None
    except batch.NoSubmissions as exc:
        raise click.BadParameter(for_terminal(str(exc), one_line=True), param_hint="SUBMISSIONS") from None
    except batch.InfrastructureError as exc:
        if pool is not None:  # the cluster cannot grade (grader.course.cluster.ClusterError): the message says why
            click.echo(f"grade batch: no learner was graded: {for_terminal(str(exc), one_line=True)}", err=True)
            sys.exit(EXIT_USAGE)
        click.echo(f"grade batch: no learner was graded: learner code cannot run here. "
                   f"{for_terminal(str(exc), one_line=True)}\n"
                   "Fix the sandbox (bubblewrap: `bwrap --version`, user namespaces) and run again, or pass "
                   "--no-sandbox to grade without it (learner code then runs as you).", err=True)
        sys.exit(EXIT_USAGE)
    counts = ", ".join(f"{n} {status}" for status, n in sorted(result["counts"].items()))
    skipped = f"; {len(result['skipped'])} skipped" if result["skipped"] else ""
    flagged = f"; {len(result['flagged'])} flagged" if result["flagged"] else ""
    click.echo(f"{plural(len(result['statuses']), 'submission')}: {counts or 'none'}{skipped}{flagged}; graded "
               f"{result['graded_now']} in {result['seconds']:.1f} s. Gradebook: {Path(out_dir) / 'gradebook.csv'}")
    for learner, message in sorted(result["messages"].items()):
        if result["statuses"][learner] in ("error", "unreadable"):
            click.echo(f"  {for_terminal(learner, one_line=True)}: {for_terminal(message, one_line=True)}", err=True)
    still_flagged = 0
    for learner, warnings in sorted(result["flagged"].items()):
        if result["statuses"].get(learner) != "graded":  # unchanged since a run that listed its flags
            still_flagged += 1
            continue
        for warning in warnings:
            click.echo(f"  flagged {for_terminal(learner, one_line=True)}: {for_terminal(warning, one_line=True)}",
                       err=True)
    if still_flagged:
        click.echo(f"  {plural(still_flagged, 'learner')} not graded again this run still flagged (as listed before; "
                   f"all in {Path(out_dir) / 'summary.html'})", err=True)
    for entry in result["skipped"]:
        click.echo(f"  skipped {for_terminal(entry.name, one_line=True)}: {for_terminal(entry.reason, one_line=True)}",
                   err=True)
    for note in result["override_problems"] + result["notes"]:
        click.echo(f"  {for_terminal(note, one_line=True)}", err=True)
    click.echo(f"{plural(len(result['changes']), 'score')} moved since the last run: {Path(out_dir) / 'changes.csv'}")
    for pair in result["similar"][:5]:
        click.echo(f"  alike: {for_terminal(pair.first, one_line=True)} and {for_terminal(pair.second, one_line=True)} "
                   f"({pair.score:.2f}; {', '.join(pair.functions[:3])}): for a person to look at, in summary.html")
    click.echo(result["isolation"], err=True)
    complete = all(s in ("graded", "unchanged") for s in result["statuses"].values()) and not any(
        entry.submission for entry in result["skipped"])
    sys.exit(EXIT_ALL_PASSED if complete else EXIT_NOT_ALL_PASSED)


def _cluster_pool(option: str | None, the_course, jobs: int | None):
    """The pool grade batch grades through: None (this machine's, grader.course.batch.LocalPool), or a
    grader.course.cluster.ClusterPool on the scheduler that --scheduler, else $DASK_SCHEDULER_ADDRESS, else the course
    file's `scheduler:` names (`local`: this machine's)."""
    for address, origin in ((option, "--scheduler"), (os.environ.get("DASK_SCHEDULER_ADDRESS"), "DASK_SCHEDULER_ADDRESS"),
                            (the_course.scheduler, the_course.where("scheduler"))):
        if address:
            break
    if not address or address.strip() == "local":
        return None
    if jobs is not None:
        raise click.UsageError(f"--jobs sizes this machine's pool, but the learners are graded on the cluster at {address} "
                               f"({origin}); pass --scheduler local to grade here")
    from grader.course import cluster
    from grader.safe_text import for_terminal

    return cluster.ClusterPool(address.strip(), say=lambda line: click.echo(f"  {for_terminal(line, one_line=True)}",
                                                                             err=True))


@main.command("worker", context_settings={"ignore_unknown_options": True})
@click.argument("scheduler")
@click.option("--nworkers", type=click.IntRange(min=1), default=None,
              help="Worker processes, each grading one learner at a time (default: one per core).")
@click.option("--no-sandbox", is_flag=True,
              help="Start where learner code cannot run behind bubblewrap: then it grades only for `grade batch "
                   "--no-sandbox` (each report's isolation line says so).")
@click.argument("dask_options", nargs=-1, type=click.UNPROCESSED)
def worker_command(scheduler: str, nworkers: int | None, no_sandbox: bool, dask_options: tuple[str, ...]) -> None:
    """Grade for `grade batch --scheduler SCHEDULER` on this machine: join the Dask scheduler as worker processes
    (`dask worker`; further options, e.g. --memory-limit 4GB, go to it). Refuses to start where learner code
    cannot run behind the sandbox or where this grader is not the running coordinator's version."""
    from grader.course import cluster
    from grader.safe_text import for_terminal

    try:
        isolation = cluster.prepare_worker(scheduler, sandboxed=not no_sandbox)
    except cluster.WorkerRefused as exc:
        click.echo(f"grade worker: not started: {for_terminal(str(exc), one_line=True)}", err=True)
        sys.exit(EXIT_USAGE)
    click.echo(f"grade worker: grader {cluster.grader_version()}, joining {scheduler}\n{isolation}", err=True)
    cluster.become(cluster.worker_command(scheduler, nworkers, dask_options))


@main.command("gradescope")
@click.argument("out", type=click.Path(dir_okay=False))
@click.option("--course", "course_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="The course configuration (default: solutions/course.yaml beside the references).")
@click.option("--chapters", "chapter_list", default="all", show_default=True, help="e.g. ch05,ch06")
@click.option("--learner-id", "learner_field", type=click.Choice(["email", "sid", "id", "name"]), default="email",
              show_default=True, help="Which field of the submitter in Gradescope's submission metadata is the "
                                      "learner id (their quiz numbers).")
@click.option("--time-budget", type=click.FloatRange(min=1), default=60, show_default=True,
              help="Seconds for one learner's code, all chapters together.")
@click.option("--sandbox", type=click.Choice(["auto", "required", "none"]), default="auto", show_default=True,
              help="auto: bubblewrap where it starts on Gradescope's image, else learner code as an unprivileged user "
                   "that cannot read the references (the autograder runs as root), else nothing is graded; required: "
                   "grade nothing without bubblewrap; none: grade without a barrier (learner code can read the "
                   "references and the course seed).")
@click.option("--force", is_flag=True, help="Replace OUT if it exists.")
def gradescope_command(out: str, course_file: str | None, chapter_list: str, learner_field: str,
                       time_budget: float, sandbox: str, force: bool) -> None:
    """Build a Gradescope autograder zip (setup.sh, run_autograder, the instructor's grader, the course
    config) that grades every submission at the course seed, hidden checks included, into Gradescope's
    results.json. It holds the references and keys: upload it to Gradescope, never hand it out."""
    from pathlib import Path

    from grader.course import gradescope

    picked = chapters_from(tuple(chapter_list.split(",")))
    the_course = _instructor_course(course_file, "grade gradescope")
    try:
        built, settings = gradescope.build(Path(out), the_course, chapters=[c.id for c in picked],
                                           learner_field=learner_field, time_budget=time_budget, sandbox=sandbox,
                                           force=force)
    except gradescope.GradescopeError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(gradescope.describe(built, settings))


@main.command("classroom")
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
    seed = _seed_here(None)
    from grader.boundary import BoundaryUnavailable

    try:
        door, isolation, reason = classroom.sandbox_for(sandbox)
    except BoundaryUnavailable as exc:
        raise click.UsageError(f"the sandbox is required and does not start here: {exc}") from None
    session = door.open_session(submission)
    from grader.core.pipeline import Request, build_report

    try:
        report = build_report(session, Request(tuple(c.id for c in picked), seed, learner=learner))
    finally:
        session.close()
    stream = sys.stderr
    click.echo(text.render(report, colour=_use_colour(stream), unicode_ok=_unicode_ok(stream), verbose=False),
               nl=False, err=True, color=_use_colour(stream))
    click.echo(isolation, err=True)
    results = lms.classroom(report, message=isolation if reason else "")
    if output_file:
        write_atomically(output_file, results)
    else:
        click.echo(results, nl=False)
    if github_output:
        with open(github_output, "a", encoding="utf-8") as handle:
            handle.write(classroom.github_output_line(results))


@main.command("regrade")
@click.argument("out", type=click.Path(exists=True, file_okay=False))
@click.option("--apply", "apply_it", is_flag=True,
              help="Record the new grades as a run of OUT/gradebook.db with --reason, and rewrite the moved learners' "
                   "reports and the class outputs (without it nothing but OUT/regrade.csv is written).")
@click.option("--reason", default=None, help="Why the grades change (required with --apply; changes.csv shows it).")
@click.option("--course", "course_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="The course configuration (default: solutions/course.yaml beside the references).")
@click.option("--overrides", "overrides_file", type=click.Path(dir_okay=False), default=None,
              help="Overrides applied as grade batch applies them (default: OUT/overrides.csv where it exists).")
@click.option("--jobs", type=click.IntRange(min=1), default=None, help="Parallel workers (default: all cores).")
@click.option("--time-budget", type=click.FloatRange(min=1), default=60, show_default=True,
              help="Seconds for one learner's code, all chapters together.")
@click.option("--no-sandbox", is_flag=True, help="Run learner code without bubblewrap even where it is installed.")
def regrade_command(out: str, apply_it: bool, reason: str | None, course_file: str | None,
                    overrides_file: str | None, jobs: int | None, time_budget: float, no_sandbox: bool) -> None:
    """Grade the submissions stored in OUT (grade batch's output folder) again with today's grader and course
    file, at the last run's seed and chapters, and show whose grade would change and why, check by check, in
    OUT/regrade.csv (learner, old_score, new_score, checks_changed, why). Nothing else changes until --apply
    records it in the history as a run with its --reason."""
    import json
    from pathlib import Path

    from grader.course import batch, regrade
    from grader.safe_text import for_terminal

    if apply_it and not (reason or "").strip():
        raise click.UsageError("--apply records the regrade with its reason: give --reason TEXT (changes.csv and "
                               "every moved learner's history show it)")
    the_course = _instructor_course(course_file, "grade regrade")
    folder = Path(out)
    try:
        found = regrade.regrade(folder, the_course, jobs=jobs, sandboxed=not no_sandbox,
                                overrides=Path(overrides_file) if overrides_file else None,
                                limits={"learner_seconds": time_budget})
    except regrade.RegradeError as exc:
        raise click.BadParameter(for_terminal(str(exc), one_line=True), param_hint="OUT") from None
    except batch.RosterError as exc:
        raise click.BadParameter(for_terminal(str(exc)), param_hint="--overrides") from None
    except batch.InfrastructureError as exc:
        click.echo(f"grade regrade: no learner was graded again: learner code cannot run here. "
                   f"{for_terminal(str(exc), one_line=True)}", err=True)
        sys.exit(EXIT_USAGE)
    written = regrade.write_csv(folder, found)
    info = found.run_info
    click.echo(f"Graded {plural(len(found.compared), 'learner')} of run {found.run} again (seed {info['seed']}, "
               f"{', '.join(json.loads(info['chapters']))}) with grader {found.grader} "
               f"(the run's: {info['grader']}).")
    moved = found.moved
    if moved:
        click.echo(f"{len(moved)} learner's grade would change:" if len(moved) == 1 else
                   f"{len(moved)} learners' grades would change:")
        for change in moved:
            new = "not graded" if change.new_score is None else f"{change.new_score:g}"
            old = "none" if change.old_score is None else f"{change.old_score:g}"
            click.echo(f"  {for_terminal(change.learner, one_line=True)}: {old} -> {new}: "
                       f"{for_terminal(change.why, one_line=True)}")
    else:
        click.echo("No learner's grade or check verdict would change.")
    for learner, why in sorted(found.left_out.items()):
        click.echo(f"  not graded again: {for_terminal(learner, one_line=True)}: {why}", err=True)
    for problem in found.override_problems:
        click.echo(f"  {for_terminal(problem, one_line=True)}", err=True)
    click.echo(f"Written: {written}")
    if apply_it:
        run = regrade.apply(folder, found, the_course, reason.strip(),
                            Path(overrides_file) if overrides_file else None)
        click.echo(f"Recorded as run {run} of {folder / 'gradebook.db'} ({for_terminal(reason.strip(), one_line=True)});"
                   f" gradebook.csv, changes.csv, junit.xml and the summary are rebuilt from it.")
    elif moved:
        click.echo("Nothing else changed: `grade regrade OUT --apply --reason TEXT` records it.")


@main.command("selftest")
@click.option("--seeds", "count", type=click.IntRange(min=1), default=None,
              help="How many seeds: the public one, the course's, then 1, 2, 3 ... [default: 25]")
@click.option("--seed", "only", type=int, default=None,
              help="Check this one seed (with the public one to compare with), as a failure's command does.")
@click.option("--chapters", "chapter_list", default="all", show_default=True, help="e.g. ch05,ch06")
@click.option("--course", "course_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="The course configuration (default: solutions/course.yaml beside the references).")
@click.option("--quizzes", "quiz_dir", type=click.Path(exists=True, file_okay=False), default=None,
              help="Question banks and their keys to check, laid out as quizzes/ is (default: the grader's own).")
@click.option("--no-code", is_flag=True, help="Check the quiz only (no reference code runs).")
@click.option("--generated", is_flag=True, help="Also weigh the slips generated from the references (grader.judging.mutants; "
              "about four times the time): those told apart at some seeds only are listed as notes.")
@click.option("--no-sandbox", is_flag=True, help="Run the reference code without bubblewrap even where it is installed.")
def selftest_command(count: int | None, only: int | None, chapter_list: str, course_file: str | None,
                     quiz_dir: str | None, no_code: bool, generated: bool, no_sandbox: bool) -> None:
    """Check the course at many seeds, not only the public one, before learners meet it (and in CI): the
    reference solutions get every check's points at every seed; every mistake a check can name is told apart
    from the right value at the check's inputs at every seed (not only at most); every parametrised quiz
    question's key is finite, well-conditioned and told apart from its known wrong answers for every learner
    draw (learner id selftest-<seed>); the reference answers get full marks. Exits 1 naming each failing check
    or question at its first failing seed, with a command that reproduces it; 0 when everything holds."""
    import time
    from pathlib import Path

    from grader.course import selftest
    from grader.safe_text import for_terminal

    picked = [c.id for c in chapters_from(tuple(chapter_list.split(",")))]
    the_course = _instructor_course(course_file, "grade selftest")
    if only is not None and count is not None:
        raise click.UsageError("--seed checks one seed, --seeds many: give one of them")
    seeds = selftest.seeds_for(count or selftest.DEFAULT_SEEDS, the_course) if only is None else \
        list(dict.fromkeys([only, selftest.seeds_for(1)[0]]))
    extra = "".join(f" {option} {value}" for option, value in (("--course", course_file), ("--quizzes", quiz_dir))
                    if value)

    def command(item: str, seed: int) -> str:
        chapter = item.split("/", 1)[0]
        text = f"grade selftest --seed {seed} --chapters {chapter}{extra}"
        if "/quiz_" in item:
            text += f"; its numbers: grade quiz {chapter} --show --learner {selftest.LEARNER_PREFIX}{seed}"
        return text

    started = time.monotonic()
    shown = ", ".join(map(str, seeds[:4])) + (" ..." if len(seeds) > 4 else "")
    click.echo(f"grade selftest: {', '.join(picked) if len(picked) < 10 else 'every chapter'} at "
               f"{plural(len(seeds), 'seed')} ({shown})", err=True)
    outcome = selftest.run(picked, seeds, the_course, quiz_dir=Path(quiz_dir) if quiz_dir else None,
                           sandbox="off" if no_sandbox else "auto", code=not no_code, command=command,
                           report=None if only is None else {only}, generated=generated)
    for failure in outcome.failures:
        more = f" (and {plural(failure.other_seeds, 'other seed')})" if failure.other_seeds else ""
        click.echo(f"FAIL {failure.item} at seed {failure.seed}{more}:")
        for problem in failure.problems:
            click.echo(f"  {for_terminal(problem, one_line=True)}")
        click.echo(f"  reproduce: {for_terminal(failure.reproduce, one_line=True)}")
    for note in outcome.notes:
        click.echo(f"note: {for_terminal(note, one_line=True)}")
    counted = ", ".join(f"{n} {what}" for what, n in outcome.counted.items())
    verdict = (f"{plural(len(outcome.failures), 'check or question', 'checks or questions')} fail"
               if outcome.failures else "everything holds")
    click.echo(f"{verdict} at {plural(len(seeds), 'seed')} ({counted}; {time.monotonic() - started:.1f} s).")
    sys.exit(EXIT_NOT_ALL_PASSED if outcome.failures else EXIT_ALL_PASSED)


EXAMPLES = {
    "run": ["grade ch06                      grade chapter 6 (code and quiz)",
            "grade ch06 H_jacobian           only that function's checks",
            "grade all --html report.html    every chapter, and a report with plots",
            "grade 6 --format json -v        machine-readable; -v adds tracebacks"],
    "list": ["grade list", "grade list --checks            also every check's id and points"],
    "quiz": ["grade quiz ch06", "grade quiz ch06 --show          the questions with your numbers and letters"],
    "classroom": ["grade classroom all --github-output \"$GITHUB_OUTPUT\"   in a GitHub Actions step",
                  "grade classroom ch06 --output results.json"],
    "release": ["grade release handout/", "grade release handout/ --course my-course.yaml --force",
                "grade release handout/ --notebooks   stubs as notebooks (Jupyter, Colab)"],
    "batch": ["grade batch submissions/ --out graded/",
              "grade batch submissions/ --out graded/ --roster roster.csv --chapters ch05,ch06 --lms canvas",
              "grade batch submissions/ --out graded/ --overrides overrides.csv --handout handout/ --similarity",
              "grade batch submissions/ --out graded/ --scheduler tcp://scheduler:8786   on a Dask cluster"],
    "worker": ["grade worker tcp://scheduler:8786", "grade worker tcp://scheduler:8786 --nworkers 8 --memory-limit 16GB"],
    "submit": ["grade submit                     pack exercises/ into <your id>.zip, checked and graded",
               "grade submit --learner ada.lovelace --out ~/handin.zip"],
    "gradescope": ["grade gradescope autograder.zip",
                   "grade gradescope autograder.zip --learner-id sid --chapters ch06,ch07"],
    "regrade": ["grade regrade graded/                     whose grade today's grader would change, and why",
                "grade regrade graded/ --apply --reason \"bearing_variance: 3 significant digits, as its hint says\""],
    "selftest": ["grade selftest                            25 seeds, every chapter (CI runs it)",
                 "grade selftest --seeds 200 --chapters ch06",
                 "grade selftest --seed 17 --chapters ch06 --quizzes my-quizzes/   one failure again"],
}


def _examples(lines: list[str]) -> str:
    return "\b\nExamples:\n" + "\n".join(f"  {line}" for line in lines)


main.epilog = _examples(["grade ch06", "grade all", "grade list", "grade quiz ch06 --show",
                         "grade batch submissions/ --out graded/"])
for _name, _command in main.commands.items():
    if _name in EXAMPLES:
        _command.epilog = _examples(EXAMPLES[_name])
