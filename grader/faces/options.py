"""What the `grade` command's commands share: reading chapter and function names, finding the submission, the
instructor's course file, and printing a report in the format asked for, with the exit status it earns."""

from __future__ import annotations

import os
import sys

import click

from grader.chapters import CHAPTERS, ChapterInfo, resolve
from grader.submission import Submission, SubmissionNotFound, locate

EXIT_ALL_PASSED, EXIT_NOT_ALL_PASSED, EXIT_USAGE = 0, 1, 2


def chapter_of_file(name: str) -> str | None:
    """The chapter whose file `name` names (exercises/ch06_measurement.py, ch06_measurement.ipynb, ch06_measurement),
    or None."""
    stem = name.replace("\\", "/").rsplit("/", 1)[-1]
    for suffix in (".py", ".ipynb"):
        stem = stem.removesuffix(suffix)
    return next((c.id for c in CHAPTERS if c.module == stem), None)


def is_chapter(name: str) -> bool:
    if name.lower() == "all":
        return True
    try:
        resolve(name)
    except KeyError:
        return False
    return True


def encode_what_the_console_can() -> None:
    """A console or redirect in a code page without ✓, σ or a learner's own characters (Windows) shows '?'
    for them instead of ending in UnicodeEncodeError; the text renderer also picks plain marks there."""
    for stream in (sys.stdout, sys.stderr):
        encoding = (getattr(stream, "encoding", None) or "").lower().replace("-", "").replace("_", "")
        if encoding not in ("utf8", "utf8sig") and hasattr(stream, "reconfigure"):
            try:
                stream.reconfigure(errors="replace")
            except (ValueError, OSError):  # a stream already written to in another way
                pass


def chapters_from(names: tuple[str, ...], param_hint: str = "CHAPTER") -> list[ChapterInfo]:
    """Chapter arguments ('ch06', 'ch6', '6', 'all') to chapters, in lesson order; BadParameter, for `param_hint`,
    naming the unknown one and the valid ones."""
    if not names:
        raise click.UsageError("name a chapter (ch00-ch09, 0-9) or 'all'; `grade list` shows them")
    if any(n.strip().lower() == "all" for n in names):
        return list(CHAPTERS)
    try:
        picked = {resolve(n).id for n in names}
    except KeyError as exc:
        raise click.BadParameter(exc.args[0], param_hint=param_hint) from None
    return [c for c in CHAPTERS if c.id in picked]


def chapters_option(text: str) -> list[ChapterInfo]:
    """The instructor's `--chapters ch05,ch06` (also 5,6 or ch6, or 'all') to chapters, in lesson order; BadParameter
    for --chapters naming the unknown one and the valid ones."""
    return chapters_from(tuple(n for n in text.split(",") if n.strip()), "--chapters")


def closest_function(name: str, owners: dict[str, str], picked: list[ChapterInfo]) -> str | None:
    """The function a mistyped `name` most likely means, case aside: first among the chapters named (`picked`),
    then among the others (`owners`: function -> its chapter); with its chapter where that is not one named."""
    import difflib

    named = {c.id for c in picked}
    mine = [f for f in owners if owners[f] in named]
    pools = [mine, [f for f in owners if f not in mine]]
    lowered = name.lower()
    for same in ([f for f in pool if f.lower() == lowered] for pool in pools):
        if same:
            return _with_chapter(same[0], owners, named)
    for pool in pools:
        by_lower = {f.lower(): f for f in pool}
        close = difflib.get_close_matches(lowered, list(by_lower), n=1)
        if close:
            return _with_chapter(by_lower[close[0]], owners, named)
    return None


def _with_chapter(function: str, owners: dict[str, str], named: set[str]) -> str:
    return function if not named or owners[function] in named else f"{function} (of {owners[function]})"


def chapters_and_functions(names: tuple[str, ...]) -> tuple[list[ChapterInfo], tuple[str, ...]]:
    """`grade ch06 H_jacobian`: the chapters named, and the functions whose checks alone are graded (a
    function alone names its chapter: `grade H_jacobian`). BadParameter for a name that is neither."""
    import re

    chapter_like = [n for n in names if is_chapter(n) or re.fullmatch(r"(ch)?\d+", n.strip(), re.I)]
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
            close = closest_function(function, owners, picked)
            hint = f"; did you mean {close}?" if close else ""
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


def use_colour(stream) -> bool:
    """Colour on a terminal. NO_COLOR (no-color.org) and FORCE_COLOR (force-color.org) count when set to
    something other than the empty string; NO_COLOR wins over FORCE_COLOR, as in Python itself."""
    if os.environ.get("NO_COLOR", ""):
        return False
    if os.environ.get("FORCE_COLOR", ""):
        return True
    return hasattr(stream, "isatty") and stream.isatty()


def unicode_ok(stream) -> bool:
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


def seed_here(seed: int | None) -> int:
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


def instructor_side(command: str) -> None:
    """A usage error where this grader is a learner's handout."""
    from grader import course_config

    if course_config.in_handout():
        raise click.UsageError(f"{command} runs on the instructor's side, with the references; this is a learner's "
                               "handout")


def instructor_course(config: str | None, command: str):
    """The instructor's course configuration; a usage error in a handout or for a broken file."""
    from grader import course_config

    instructor_side(command)
    from grader.core.pipeline import instructor_course

    try:
        return instructor_course(config)
    except course_config.CourseError as exc:
        raise click.BadParameter(str(exc), param_hint="--course") from None


def handout_id(given: str) -> str:
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


def renderer_for(output_format: str):
    """The module that prints a report in `output_format` (grader.render.json_report or .text)."""
    if output_format == "json":
        from grader.render import json_report

        return json_report
    from grader.render import text

    return text


def report_text(report, output_format: str, verbose: bool) -> str:
    """The report as the chosen format prints it on stdout."""
    renderer = renderer_for(output_format)
    if output_format == "json":
        return renderer.render(report)
    stream = sys.stdout
    return renderer.render(report, colour=use_colour(stream), unicode_ok=unicode_ok(stream), verbose=verbose)


def emit(report, output_format: str, verbose: bool, isolation: str = "", shown: str | None = None) -> None:
    """Print the report in the chosen format (`shown`: as report_text made it already) and exit 0 (all passed) or 1;
    with `verbose`, the isolation line (what held for the learner's code) first, on stderr."""
    if verbose and isolation:
        click.echo(isolation, err=True)
    text = report_text(report, output_format, verbose) if shown is None else shown
    click.echo(text, nl=False, color=None if output_format == "json" else use_colour(sys.stdout))
    sys.exit(EXIT_ALL_PASSED if report.all_passed else EXIT_NOT_ALL_PASSED)
