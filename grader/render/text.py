"""The terminal renderer: one line per check with a mark and points, then chapter totals."""

from __future__ import annotations

import click

from grader import provenance, safe_text
from grader.model import CheckResult, Report, Status, not_written
from grader.render import plural

_MARKS = {Status.PASS: ("✓", "PASS"), Status.FAIL: ("✗", "FAIL"), Status.ERROR: ("!", "ERR "),
          Status.SKIP: ("-", "SKIP"), Status.RECORDED: ("•", "REC ")}
_COLOURS = {Status.PASS: "green", Status.FAIL: "red", Status.ERROR: "magenta", Status.SKIP: "yellow",
            Status.RECORDED: "cyan"}


def _points(value: float) -> str:
    return f"{value:g}"


def _mark(status: Status, unicode_ok: bool) -> str:
    symbol, word = _MARKS[status]
    return symbol if unicode_ok else word


def render_check(check: CheckResult, *, colour: bool, unicode_ok: bool, verbose: bool, chapter: str = "") -> list[str]:
    """The check's line (a check that did not pass ends with its stable id, chNN/check_id) and its message."""
    mark = click.style(_mark(check.status, unicode_ok), fg=_COLOURS[check.status], bold=True) if colour \
        else _mark(check.status, unicode_ok)
    label = "quiz " if check.kind == "quiz" else ""
    points = "practice" if check.practice else f"{_points(check.max_points)} pending" \
        if check.status == Status.RECORDED else f"{_points(check.points)}/{_points(check.max_points)}"
    line = f"  {mark} [{points}] {label}{check.description}"
    if chapter and check.status not in (Status.PASS, Status.RECORDED):
        line += f"  ({chapter}/{check.id})"
    lines = [line]
    if check.status not in (Status.PASS, Status.RECORDED) and check.message:
        for text in check.message.splitlines():
            lines.append(f"      {text}")
        trace = check.details.get("traceback")
        if trace and verbose:
            lines.extend(f"      | {t}" for t in trace.splitlines())
    if check.status not in (Status.PASS, Status.RECORDED) and check.help:
        lines.append(f"      hint: {check.help}")  # what to change, apart from what is wrong
    return lines


def _folded_line(function: str, checks: list[CheckResult], colour: bool, unicode_ok: bool) -> str:
    mark = _mark(Status.FAIL, unicode_ok)
    mark = click.style(mark, fg=_COLOURS[Status.FAIL], bold=True) if colour else mark
    worth = sum(c.max_points for c in checks)
    return f"  {mark} [0/{_points(worth)}] {function}: not implemented yet ({plural(len(checks), 'check')}; -v lists them)"


def start_here(report: Report) -> list[str]:
    """On untouched stubs, where to begin: the first function not written yet, and its worked example."""
    code = [c for ch in report.chapters for c in ch.checks if c.kind == "code"]
    if not code or any(c.status == Status.PASS for c in code):
        return []
    chapter = next(ch for ch in report.chapters if any(c.kind == "code" for c in ch.checks))
    untouched = not_written([c for c in chapter.checks if c.kind == "code"])
    if not untouched:
        return []
    function, checks = next(iter(untouched.items()))
    from grader.chapters import BY_ID

    where = "your notebook" if chapter.source.startswith("the code") else \
        chapter.source or f"exercises/{BY_ID[chapter.chapter].module}.py"  # the file graded: maybe a notebook
    return [f"Start here: write {function} in {where} (its docstring says what it "
            f"computes); the first check is: {checks[0].description}. Then run `grade {chapter.chapter}` again.", ""]


def _pending_note(points: float, what: str) -> str:
    return f" (+{plural(points, 'point')} {what})" if points > 0 else ""


def total_line(name: str, score: float, max_score: float, hidden_checks: int, hidden_points: float,
               recorded: float) -> str:
    """"ch06 total: 22/22" where everything was checked here; else what it is: "ch06 public checks: 22/22; 2
    hidden checks (3 points) run when you submit; 4 points of recorded quiz answers are graded when you
    submit". Without a `name` (all chapters): "Total: ..." and "Total of the public checks: ..."."""
    if not hidden_checks and recorded <= 0:
        return f"{name} total: {_points(score)}/{_points(max_score)}" if name else \
            f"Total: {_points(score)}/{_points(max_score)}"
    parts = [f"{name} public checks: {_points(score)}/{_points(max_score)}" if name else
             f"Total of the public checks: {_points(score)}/{_points(max_score)}"]
    if hidden_checks:
        parts.append(f"{plural(hidden_checks, 'hidden check')} ({plural(hidden_points, 'point')}) "
                     f"{'runs' if hidden_checks == 1 else 'run'} when you submit")
    if recorded > 0:
        parts.append(f"{plural(recorded, 'point')} of recorded quiz answers {'is' if recorded == 1 else 'are'} "
                     "graded when you submit")
    return "; ".join(parts)


def adjustment_lines(adjustments) -> list[str]:
    """Overrides and late penalties, one line each."""
    return [f"{'late penalty' if a.kind == 'late' else 'override'}: {a.describe()}" for a in adjustments]


def verdict_line(report: Report) -> str:
    """One line that claims no more than was checked: with hidden checks or recorded answers, only
    the public checks can be said to pass."""
    if not report.all_passed:
        return "Not all checks pass yet: see the marks above."
    if report.pending_score > 0:
        return (f"All public checks pass; {plural(report.pending_score, 'more point')} "
                f"{'is' if report.pending_score == 1 else 'are'} graded when you submit "
                "(hidden checks, recorded quiz answers).")
    return "All checks pass."


def render(report: Report, *, colour: bool = False, unicode_ok: bool = True, verbose: bool = False) -> str:
    """The whole report as text; `colour` adds ANSI styles, `unicode_ok` picks the marks. Learner text
    (messages, tracebacks, printed output, ids) reaches the terminal without its control characters
    and escape sequences (grader.safe_text.for_terminal): only this renderer's own styles remain."""
    report = safe_text.clean_report(report, safe_text.for_terminal)
    out: list[str] = start_here(report)
    if report.learner and any(c.kind == "quiz" for ch in report.chapters for c in ch.checks):
        out.append(f"Quiz answers graded for learner {report.learner}.")
        if report.learner_unset:
            out.append(f"Your quiz numbers and option letters are those of {report.learner_id!r} until you put "
                       "`learner: your-id` (as your course lists you) in exercises/answers/learner.yaml: do that before "
                       "you work on the quiz, and see your own with `grade quiz chNN --show`.")
    for chapter in report.chapters:
        title = f"{chapter.chapter}  {chapter.title}"
        out.append(click.style(title, bold=True) if colour else title)
        if not chapter.unread and (chapter.source.endswith(".ipynb") or chapter.source.startswith("the code")):
            out.append(f"  graded: {chapter.source}")  # a file that could not be read: its problem says so
        for note in chapter.notes:
            out.append(f"  note: {note}")
        for problem in chapter.problems:
            out.extend(f"  {line}" for line in problem.splitlines())
        for kind, heading in (("code", "code"), ("quiz", "quiz")):
            checks = [c for c in chapter.checks if c.kind == kind]
            if not checks:
                continue
            if kind == "quiz" and all(c.practice for c in checks):
                right = sum(c.status == Status.PASS for c in checks)
                out.append(f"  quiz (practice, not counted): {right} of {len(checks)} right")
            elif any(c.kind == "quiz" for c in chapter.checks):
                out.append(f"  {heading}: {_points(chapter.score_of(kind))}/{_points(chapter.max_score_of(kind))}"
                           + _pending_note(chapter.recorded_score_of(kind), "recorded, graded when you submit"))
            if kind == "code" and len(checks) > 1 and all(c.status == Status.ERROR for c in checks) \
                    and len({c.message for c in checks}) == 1:  # the file did not import: one line says it
                mark = _mark(Status.ERROR, unicode_ok)
                mark = click.style(mark, fg=_COLOURS[Status.ERROR], bold=True) if colour else mark
                out.append(f"  {mark} [0/{_points(sum(c.max_points for c in checks))}] none of the "
                           f"{len(checks)} checks ran: {checks[0].message.split(': ', 1)[-1]}")
                continue
            folded = not_written(checks) if kind == "code" and not verbose else {}
            for check in checks:
                if check.function not in folded:
                    out.extend(render_check(check, colour=colour, unicode_ok=unicode_ok, verbose=verbose,
                                            chapter=chapter.chapter))
                elif check is folded[check.function][0]:  # one line for a function not written yet
                    out.append(_folded_line(check.function, folded[check.function], colour, unicode_ok))
        out.append("  " + total_line(chapter.chapter, chapter.score, chapter.max_score, chapter.hidden_checks,
                                     chapter.hidden_points, chapter.recorded_score_of()))
        out.extend(f"  {line}" for line in adjustment_lines(chapter.adjustments))
        out.append("")
    if len(report.chapters) > 1:
        out.append(total_line("", report.score, report.max_score,
                                         sum(ch.hidden_checks for ch in report.chapters),
                                         sum(ch.hidden_points for ch in report.chapters),
                                         sum(ch.recorded_score_of() for ch in report.chapters)))
    out.extend(adjustment_lines(report.adjustments))
    out.append(verdict_line(report))
    out.append(provenance.footer(report))
    if verbose and report.learner_output.strip():
        out.append("What your code printed while it was graded:")
        out.extend(f"  | {line}" for line in report.learner_output.splitlines()[:50])
    return "\n".join(out).rstrip() + "\n"
