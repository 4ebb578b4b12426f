"""`grade regrade OUT`: grade a batch's stored submissions again with today's grader, and say whose grade would change,
check by check, before anything changes.

The stored submissions are the staged copies grade batch keeps (one record per learner in OUT/.staging/.records,
grader.course.staging.keep: exactly the files it graded; an older grader's OUT/.staging/<folder>/exercises is read
as well). Each learner graded in the batch's last finished run (grader.course.history) is graded again through
the one transaction, behind the sandbox as a batch grades, with what that run graded with (its settings: the course
file's and the overrides' text as read then, its seed and chapters) unless another course file or overrides file is
named (--course, --overrides: each difference is listed), and compared with what that run recorded: the score, the
adjustments and every check's verdict and points. The learners that move are printed and written into
OUT/regrade.csv (learner, old_score, new_score, checks_changed, why); nothing else is written. With `apply` (and a
reason) the new grades become a run of the history that carries the reason and the settings it graded with, the
moved learners' files are written again, and every class output is rebuilt from the history
(grader.course.outputs.rebuild).
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from grader import provenance
from grader.boundary import SandboxMode
from grader.course import history as histories
from grader.course import outputs
from grader.course.overrides import by_learner, in_force
from grader.course.settings import RunSettings, Source, differences
from grader.course.staging import folder_name
from grader.course.workers import Grading, LocalPool, Outcome, staged_again
from grader.course_config import CourseError
from grader.files import write_atomically
from grader.model import Report, points_text, rounded_points
from grader.safe_text import for_csv

if TYPE_CHECKING:
    from grader.course_config import Course

CSV_NAME = "regrade.csv"
COLUMNS = ("learner", "old_score", "new_score", "checks_changed", "why")


class RegradeError(ValueError):
    """OUT holds nothing to regrade (no history, no finished run); the message says what it holds."""


@dataclass
class Moved:
    """One learner compared: their score as the run recorded it and as graded today, the checks whose verdict or
    points changed (in words), whether the adjustments changed, and why in one line. `new_score` None: could not be
    graded again."""

    learner: str
    old_score: float | None
    new_score: float | None
    checks: list[str] = field(default_factory=list)  # stable ids
    why: str = ""
    adjusted: bool = False  # the overrides or the late penalty made other adjustments

    @property
    def moves(self) -> bool:
        return self.new_score is None or self.new_score != self.old_score or bool(self.checks) or self.adjusted


@dataclass
class Regrade:
    """What a regrade found: the run it regraded (its id and data), the settings it graded with and how they differ
    from the run's, every learner compared, the learners it could not regrade (no stored submission), the overrides
    that could not apply, notes, today's grader version and the isolation line; each learner's outcome; and (after
    apply) the run that recorded it."""

    run: int
    run_info: dict
    settings: RunSettings
    differences: list[str]
    compared: list[Moved]
    left_out: dict[str, str]
    override_problems: list[str]
    notes: list[str]
    isolation: str
    outcomes: dict[str, Outcome] = field(default_factory=dict, repr=False)
    rows: list = field(default_factory=list, repr=False)
    course: Course | None = None
    recorded: int | None = None

    @property
    def moved(self) -> list[Moved]:
        return [m for m in self.compared if m.moves]

    @property
    def grader(self) -> str:
        return self.settings.grader


def _verdicts(report: Report) -> dict[str, tuple[str, float]]:
    """Every check's (status, points) by its stable id."""
    return {f"{chapter.chapter}/{check.id}": (check.status.value, rounded_points(check.points))
            for chapter in report.chapters for check in chapter.checks}


def compare(learner: str, old_score: float | None, old: Report | None, new: Report | None, why_not: str = "") -> Moved:
    """How `learner`'s grade moves from the recorded `old` report (its score as the gradebook had it) to `new`."""
    if new is None:
        return Moved(learner, old_score, None, [], f"could not be graded again: {why_not}")
    before, after = _verdicts(old) if old is not None else {}, _verdicts(new)
    changed, said = [], []
    for key in list(before) + [k for k in after if k not in before]:
        if before.get(key) == after.get(key):
            continue
        changed.append(key)
        if key not in after:
            said.append(f"{key} no longer graded (was {before[key][0]}, {before[key][1]:g})")
        elif key not in before:
            said.append(f"{key} graded now: {after[key][0]} ({after[key][1]:g})")
        else:
            (was, had), (now, has) = before[key], after[key]
            verdict = f"{was} -> {now}" if was != now else now
            said.append(f"{key} {verdict} ({has - had:+g})")
    if old is not None and old.grader != new.grader and (changed or new.score != old_score):
        said.append(f"grader {old.grader or 'unknown'} -> {new.grader}")
    adjusted = old is not None and ([a.to_dict() for a in old.all_adjustments()]
                                    != [a.to_dict() for a in new.all_adjustments()])
    if adjusted:
        said.append("overrides or late penalty changed: " + ("; ".join(a.describe() for a in new.all_adjustments())
                                                             or "none now"))
    return Moved(learner, old_score, new.score, changed, "; ".join(said), adjusted)


def regrade(out: Path, course: Course | None = None, *, overrides: Path | None = None, jobs: int | None = None,
            sandboxed: bool = True, time_budget: float | None = None,
            progress: Callable[[int, int], None] | None = None, pool=None) -> Regrade:
    """Grade every learner graded in OUT's last finished run again (today's grader), with that run's settings but
    for a course file (`course`) or an overrides file (`overrides`) named here, and compare. Writes nothing.
    RegradeError where OUT holds no finished run; grader.course.workers.InfrastructureError where learner code
    cannot run here; grader.course.overrides.OverridesError for an overrides file that cannot be read."""
    if not (out / histories.FILE_NAME).is_file():
        raise RegradeError(f"{out} holds no {histories.FILE_NAME}: regrade a folder `grade batch --out` wrote")
    with histories.History(out / histories.FILE_NAME) as history:
        run = history.last_finished()
        if run is None:
            raise RegradeError(f"{out / histories.FILE_NAME} has no finished run yet: let `grade batch` finish first")
        info, results, before = history.run_info(run), history.results(run), history.settings(run)
        old = {learner: history.report(result) or _written_report(out, learner)
               for learner, result in results.items() if result.status == "graded"}
    notes = []
    if before is None:  # a history from a grader that kept no settings: the course file and overrides of today
        notes.append(f"run {run} kept no record of what it graded with (an earlier grader's history): graded with "
                     "the course file and the overrides file as they are now")
        before = RunSettings(tuple(json.loads(info["chapters"])), int(info["seed"]), "the run",
                             Source.read(Path(course.source)) if course and course.source else Source(),
                             Source.read(out / "overrides.csv"), handout=info["handout"], grader=info["grader"])
    overrides_path = overrides or Path(before.overrides.path or out / "overrides.csv")
    settings = before.with_(
        course=Source.read(Path(course.source)) if course is not None and course.source else before.course,
        overrides=Source.read(overrides) if overrides is not None else before.overrides,
        handout=course.current_handout if course is not None else before.handout,
        time_budget=time_budget if time_budget is not None else before.time_budget,
        sandbox=(SandboxMode.REQUIRED if sandboxed else SandboxMode.OFF).value, grader=provenance.grader_version())
    if overrides is None and (out / "overrides.csv").is_file() and not before.overrides.path:
        notes.append(f"{out / 'overrides.csv'} is there, but run {run} read no overrides: `--overrides "
                     f"{out / 'overrides.csv'}` grades with it")
    elif overrides is None and before.overrides.path and Source.read(Path(before.overrides.path)) != before.overrides:
        notes.append(f"{before.overrides.path} changed since run {run} read it: graded with the rows as run {run} read "
                     f"them; `--overrides {before.overrides.path}` grades with the file as it is now")
    try:
        the_course = course if course is not None else settings.course_file()
    except CourseError as exc:
        raise RegradeError(f"run {run}'s course file cannot be read again ({exc}): name one with --course") from None
    chapters = list(settings.chapters)
    graded = [learner for learner, result in results.items() if result.status == "graded"]
    rows, problems = (in_force(overrides_path, graded, chapters, text=settings.overrides.text)
                      if settings.overrides.text is not None else ([], []))
    rows_of = by_learner(rows)
    grading = Grading(tuple(chapters), settings.seed, settings.html, settings.plots,
                      {"learner_seconds": settings.time_budget}, settings.sandbox,
                      frozenset(the_course.hidden) if the_course else frozenset(), the_course, render=False)
    tasks, left_out = [], {}
    for learner in graded:
        staged = staged_again(out, learner, results[learner], grading, rows_of.get(learner, ()))
        if staged is None:
            left_out[learner] = "its stored submission is gone (OUT/.staging)"
        else:
            tasks.append(staged)
    pool = pool or LocalPool(jobs)
    isolation = pool.isolation(settings.sandbox)
    compared, found = [], {}
    for done, outcome in enumerate(pool.grade(tasks, out, grading, rows_of, force=True), 1):
        new = outcome.report if outcome.status == "graded" else None
        learner = outcome.learner
        found[learner] = outcome
        compared.append(compare(learner, results[learner].score, old.get(learner), new, outcome.message))
        if progress is not None:
            progress(done, len(tasks))
    compared.sort(key=lambda m: graded.index(m.learner))
    return Regrade(run, info, settings, differences(before, settings), compared, left_out, problems, notes, isolation,
                   found, rows, the_course)


def _written_report(out: Path, learner: str) -> Report | None:
    """The report an earlier grader wrote into OUT/<folder>/report.json, where its history kept none (a history from
    before reports were kept there), or None."""
    try:
        return Report.from_dict(json.loads((out / folder_name(learner) / "report.json").read_text(encoding="utf-8")))
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return None


def csv_text(found: Regrade) -> str:
    """regrade.csv: a row per learner whose grade, any check's verdict or adjustments would move."""
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    writer.writerow(COLUMNS)
    for moved in found.moved:
        writer.writerow([for_csv(moved.learner), points_text(moved.old_score), points_text(moved.new_score),
                         for_csv(" ".join(moved.checks)), for_csv(moved.why)])
    return buffer.getvalue()


def write_csv(out: Path, found: Regrade) -> Path:
    path = out / CSV_NAME
    write_atomically(path, csv_text(found))
    return path


def apply(out: Path, found: Regrade, reason: str) -> tuple[int, list[str]]:
    """Record the regrade as a run of the history with `reason` and the settings it graded with: the moved
    learners' new results (their files written again), every other learner of the regraded run kept as it was,
    and every class output rebuilt from the new run. Returns the run's id and what the rebuild noted for the
    instructor (a gradebook edited by hand, learners without a trusted time)."""
    from grader.course.batch import Recorder

    moved = {m.learner for m in found.moved if m.new_score is not None}
    with histories.History(out / histories.FILE_NAME) as history:
        before = history.results(found.run)
        kept, latest = history.before()
        run = history.start(found.settings, found.course.id if found.course else found.run_info["course"],
                            reason=reason)
        grading = Grading(tuple(found.settings.chapters), found.settings.seed, found.settings.html,
                          found.settings.plots, {}, found.settings.sandbox,
                          frozenset(found.course.hidden) if found.course else frozenset(), found.course)
        recorder = Recorder(out, history, run, grading, kept, latest)
        for learner, result in before.items():
            if learner in moved:
                recorder.record(found.outcomes[learner])
            else:
                history.record(run, result)
        said = {(learner, source): text for learner, outcome in found.outcomes.items() if learner not in moved
                for source, _, text in outcome.outcomes}
        said.update(recorder.outcomes)
        graded = {learner for learner, result in before.items() if result.status == "graded"}
        rebuilt = outputs.rebuild(out, history, run, found.settings,
                                  overrides=outputs.override_rows(found.rows, said, graded),
                                  notes=found.override_problems + found.notes, isolation=found.isolation)
    found.recorded = run
    return run, rebuilt.notes
