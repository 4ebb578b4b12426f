"""What `grade review OUT` shows and records: a batch's class and each learner, read from the history
(grader.course.history) and OUT's own files, and an override recorded through the history.

Reading: `class_view` gives a row per learner of the last finished run (total, chapters, late or untimed, not
graded, overrides, similar partners, named mistakes, failing checks); `learner_view` gives one learner's stored
submission (OUT/.staging: exactly the files graded), each failing check with its message and named mistake and the
lines of the function it blames, and their grade's history, run by run. Nothing here runs learner code or reads
anything outside OUT.

Recording: `record_override` adds one row to the overrides file the last run read (or OUT/overrides.csv) and
records a run of the history in one transaction: the learner's kept report adjusted by the overrides now in force
(no grading), every other learner as the last run had them, and every class output rebuilt
(grader.course.outputs.rebuild). It is refused, saying what changed, when the history moved on since the page it
came from was made (`seen_run`): two saves of one page never overwrite each other. Undo is another row.
"""

from __future__ import annotations

import csv
import io
import json
import threading
import zlib
from dataclasses import dataclass, field
from pathlib import Path

from grader.course import history as histories
from grader.course import outputs
from grader.course.overrides import OverridesError, by_learner, in_force
from grader.course.settings import Source
from grader.course.similarity import function_lines
from grader.course.staging import STAGING, folder_name, kept_files
from grader.course.workers import Grading, Outcome, staged_again
from grader.files import write_atomically
from grader.model import Adjustment, Status

TARGETS_HELP = "a check (chNN/check_id), a chapter (chNN), total, or late (its factor: 0 waives it)"
_SAVING = threading.Lock()  # one save at a time in this process; the history's run ids order them across processes


class ReviewError(ValueError):
    """A request the review cannot meet (no history, no such learner, a bad override); the message says why."""


class StaleError(ReviewError):
    """The history moved on since the page was made: the message says what was recorded since."""


@dataclass
class ClassRow:
    learner: str
    status: str  # graded, unreadable, error
    message: str
    score: float | None
    max_score: float | None
    chapters: dict[str, float | None]
    late: str  # "" or what the late penalty did
    untimed: bool
    overrides: list[str]  # each adjustment in words
    similar: list[str]  # learners whose code is most alike (summary.json's pairs)
    mistakes: list[str]  # "ch06/H_jacobian: transpose"
    failing: list[str]  # stable ids of the checks failed on their own
    flags: list[str]


@dataclass
class ClassView:
    run: int
    run_info: dict
    chapters: list[str]
    rows: list[ClassRow]
    mistakes: list[str] = field(default_factory=list)  # every named mistake of the class, for the filter
    checks: list[str] = field(default_factory=list)  # every check failed by someone


@dataclass
class Blame:
    chapter: str
    check: str  # stable id
    function: str
    status: str
    points: float
    max_points: float
    message: str
    mistake: str
    help: str
    file: str  # the file of the function it blames, as in `files`
    lines: tuple[int, int] | None  # the function's first and last line there


@dataclass
class LearnerView:
    run: int
    learner: str
    row: ClassRow
    files: dict[str, str]  # path in exercises/ -> text (as UTF-8, undecodable bytes replaced)
    blames: list[Blame]
    history: list[dict]  # per run: run, started, reason, score, adjustments in words
    overrides: list[dict]  # the rows in force for this learner: target, points, factor, reason, who, said
    pairs: list[dict]  # summary.json's similar pairs with this learner
    report_html: str | None  # OUT-relative path of their report.html, where there is one


def _history(out: Path) -> histories.History:
    path = out / histories.FILE_NAME
    if not path.is_file():
        raise ReviewError(f"{out} holds no {histories.FILE_NAME}: review a folder `grade batch --out` wrote")
    return histories.History(path)


def _summary(out: Path) -> dict:
    try:
        return json.loads((out / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def _judged_data(history: histories.History, sha: str | None) -> dict | None:
    """A kept report as plain data (the class page reads its checks' verdicts, never builds the Report)."""
    if not sha:
        return None
    row = history.db.execute("SELECT data FROM reports WHERE sha = ?", (sha,)).fetchone()
    return None if row is None else json.loads(zlib.decompress(row["data"]).decode("utf-8", "surrogatepass"))


def _pairs_of(out: Path) -> list[tuple[str, str, float]]:
    """The similar pairs summary.json lists (grade batch --similarity), most alike first: both learners, the score."""
    found = []
    for pair in _summary(out).get("similar", []):
        learners = pair.get("learners") if isinstance(pair, dict) else None
        if isinstance(learners, list) and len(learners) == 2 and all(isinstance(x, str) for x in learners):
            score = pair.get("score")
            found.append((learners[0], learners[1], float(score) if isinstance(score, (int, float)) else 0.0))
    return found


def _row(history: histories.History, result, similar: dict[str, list[str]], seen: dict, deadline: bool) -> ClassRow:
    """One learner's row; `seen` keeps what each kept report (by its hash) said, for learners whose report is
    another's byte for byte; `deadline`: the run's course has one, so a learner without a trusted time (the
    roster's, as the class summary counts them) is untimed."""
    sha = result.report if result.status == "graded" else None
    if sha not in seen:
        mistakes, failing = [], []
        for chapter in (_judged_data(history, sha) or {}).get("chapters", []):
            for check in chapter.get("checks", []):
                if check.get("status") == Status.FAIL.value and not check.get("upstream"):
                    failing.append(f"{chapter['chapter']}/{check['id']}")
                    if check.get("mistake"):
                        mistakes.append(f"{chapter['chapter']}/{check['function']}: {check['mistake']}")
        seen[sha] = (list(dict.fromkeys(mistakes)), failing)
    mistakes, failing = seen[sha]
    late = "; ".join(Adjustment.said(a) for a in result.adjustments if (a.get("kind") or "") == "late")
    return ClassRow(result.learner, result.status, result.message, result.score, result.max_score,
                    {c: v.get("score") for c, v in (result.chapters or {}).items()}, late,
                    deadline and result.status == "graded" and result.time_from != "roster",
                    [Adjustment.said(a) for a in result.adjustments if (a.get("kind") or "") != "late"],
                    similar.get(result.learner, []), list(mistakes), list(failing), list(result.flags or []))


def last_run(out: Path) -> int | None:
    """The id of OUT's last finished run (None: none yet): what a kept class_view was made from."""
    with _history(out) as history:
        return history.last_finished()


def class_view(out: Path, seen: dict | None = None) -> ClassView:
    """Every learner of OUT's last finished run, in the class's order; `seen`: what each kept report said, by its
    hash, kept by the caller from one view to the next (a report's hash names its content: it never goes stale)."""
    similar: dict[str, list[str]] = {}
    for first, second, _ in _pairs_of(out):
        similar.setdefault(first, []).append(second)
        similar.setdefault(second, []).append(first)
    with _history(out) as history:
        run = history.last_finished()
        if run is None:
            raise ReviewError(f"{out / histories.FILE_NAME} has no finished run yet: let `grade batch` finish first")
        info, results, settings = history.run_info(run), history.results(run), history.settings(run)
        order = outputs.class_order(list(results), settings)
        seen = {} if seen is None else seen
        deadline = settings is not None and outputs.has_deadline(settings)
        rows = [_row(history, results[learner], similar, seen, deadline) for learner in order]
    chapters = list(settings.chapters) if settings else sorted({c for r in rows for c in r.chapters})
    return ClassView(run, info, chapters, rows, sorted({m for r in rows for m in r.mistakes}),
                     sorted({c for r in rows for c in r.failing}))


def learner_view(out: Path, learner: str, view: ClassView | None = None) -> LearnerView:
    """One learner of OUT's last finished run (`view`: its class_view, where the caller keeps it): ReviewError where
    it has none of that name."""
    view = view or class_view(out)
    row = next((each for each in view.rows if each.learner == learner), None)
    if row is None:
        raise ReviewError(f"run {view.run} has no learner {learner!r}")
    files = {name: data.decode("utf-8", "replace")
             for name, data in sorted((kept_files(out / STAGING, learner) or {}).items(),
                                      key=lambda item: ("/" in item[0], item[0].rsplit("/", 1)[-1]))  # chapters first
             if name.rsplit("/", 1)[-1] != "__init__.py" and name.endswith((".py", ".ipynb", ".yaml", ".yml"))}
    where = {}
    for name, text in files.items():
        if name.endswith(".py"):
            for function, lines in function_lines(text).items():
                where.setdefault((name[:4], function), (name, lines))
    blames, history_rows, in_force_rows = [], [], []
    with _history(out) as history:
        result = history.result(view.run, learner)
        report = history.judged(result.report) if result and result.status == "graded" else None
        for chapter in report.chapters if report else []:
            for check in chapter.checks:
                if check.status in (Status.FAIL, Status.ERROR):
                    file, lines = where.get((chapter.chapter, check.function), ("", None))
                    blames.append(Blame(chapter.chapter, f"{chapter.chapter}/{check.id}", check.function,
                                        check.status.value, check.points, check.max_points, check.message,
                                        check.mistake or "", check.help or "", file, lines))
        for run_row in history.db.execute(
                "SELECT r.id, r.started, r.reason, x.score, x.adjustments, x.status FROM runs r JOIN results x ON "
                "x.run = r.id WHERE x.learner = ? AND r.finished IS NOT NULL ORDER BY r.id", (learner,)):
            adjustments = json.loads(run_row["adjustments"] or "[]")
            history_rows.append({"run": run_row["id"], "started": run_row["started"], "reason": run_row["reason"] or
                                 "grade batch", "status": run_row["status"], "score": run_row["score"],
                                 "adjustments": [Adjustment.said(a) for a in adjustments]})
        for o in history.db.execute("SELECT * FROM overrides WHERE run = ? AND learner = ?", (view.run, learner)):
            in_force_rows.append(dict(o))
    pairs = [{"first": first, "second": second, "score": score} for first, second, score in _pairs_of(out)
             if learner in (first, second)]
    report_html = f"{folder_name(learner)}/report.html" if (out / folder_name(learner) / "report.html").is_file() \
        else None
    return LearnerView(view.run, learner, row, files, blames, history_rows, in_force_rows, pairs, report_html)


def record_override(out: Path, learner: str, target: str, points: float | None, factor: float | None, reason: str,
                    who: str, seen_run: int) -> int:
    """Record an override of `learner` (points, or a factor for `late`) with its reason and who made it, through the
    history: a new run (its id is returned) with the learner's kept report adjusted, and every class output rebuilt.
    StaleError where a run was recorded after `seen_run` or the file was edited since; ReviewError for a row that
    cannot apply."""
    reason, who, target = reason.strip(), who.strip(), (target.strip() or "total")
    if not reason:
        raise ReviewError("every override needs its reason (the learner reads it)")
    if not who:
        raise ReviewError("say who makes the override")
    if (points is None) == (factor is None):
        raise ReviewError("give points or a factor, one of them")
    with _SAVING, _history(out) as history:
        run = history.last_finished()
        if run != seen_run:
            info = history.run_info(run) if run is not None else {}
            raise StaleError(f"run {run} ({info.get('reason') or 'grade batch'}, {info.get('started')}) was recorded "
                             f"after run {seen_run}, which this page shows: reload it and save again")
        results, settings = history.results(run), history.settings(run)
        if settings is None:
            raise ReviewError(f"run {run} kept no record of what it graded with: run `grade batch` once first")
        result = results.get(learner)
        if result is None or result.status != "graded" or not result.report:
            raise ReviewError(f"{learner!r} has no graded report in run {run}: nothing to override")
        path = Path(settings.overrides.path) if settings.overrides.path else out / "overrides.csv"
        candidate = (settings.overrides.text if settings.overrides.text is not None else "")
        if (Source.read(path).text or "") != candidate:  # edited by hand since: this run would record other rows
            raise StaleError(f"{path.name} changed since run {run} read it: grade the batch again (it reads the "
                             "file as it is now), then record here")
        row = [learner, target, "" if points is None else f"{points:g}", "" if factor is None else f"{factor:g}",
               reason, who]
        buffer = io.StringIO()
        csv.writer(buffer, lineterminator="\n").writerow(row)
        graded = [name for name, r in results.items() if r.status == "graded"]
        chapters = list(settings.chapters)
        header = "" if candidate.strip() else "learner,target,points,factor,reason,who\n"
        text = candidate + ("" if not candidate or candidate.endswith("\n") else "\n") + header + buffer.getvalue()
        try:
            rows, problems = in_force(path, graded, chapters, text=text)
            before = in_force(path, graded, chapters, text=candidate)[0] if candidate.strip() else []
        except OverridesError as exc:
            raise ReviewError(f"{exc}: fix the file by hand first") from None
        if len(rows) == len(before):  # the new row is not in force: the reason is the last problem
            raise ReviewError(f"the override cannot apply: {'; '.join(problems[-1:]) or TARGETS_HELP}")
        settings = settings.with_(overrides=Source(str(path), text))
        course = settings.course_file()
        grading = Grading(tuple(chapters), settings.seed, settings.html, settings.plots, {}, settings.sandbox,
                          frozenset(course.hidden) if course else frozenset(), course)
        kept, latest = history.before()
        staged = staged_again(out, learner, result, grading, tuple(by_learner(rows).get(learner, ())))
        if staged is None or learner not in kept:
            raise ReviewError(f"{learner!r}'s stored submission (OUT/.staging) or kept report is gone: grade the batch "
                              "again first")
        write_atomically(path, text)  # the file as it was read (checked above), and the row: what the run records
        run_now = history.start(settings, course.id if course else None,
                                reason=f"override by {who} in grade review: {learner} {target}: {reason}")
        from grader.course.batch import Recorder

        recorder = Recorder(out, history, run_now, grading, kept, latest)
        for name, result_then in results.items():
            if name == learner:
                recorder.record(Outcome(name, "unchanged", "already graded, files unchanged", staged))
            else:
                history.record(run_now, result_then)
        said = {(o["learner"], o["source"]): o["applied"] for o in history.db.execute(
            "SELECT learner, source, applied FROM overrides WHERE run = ?", (run,))}
        said.update(recorder.outcomes)
        outputs.rebuild(out, history, run_now, settings, overrides=outputs.override_rows(rows, said, set(graded)),
                        notes=problems)
    return run_now
