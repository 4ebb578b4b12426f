"""`grade regrade OUT`: grade a batch's stored submissions again with today's grader and course file, and say whose
grade would change, check by check, before anything changes.

The stored submissions are the staged copies grade batch keeps (OUT/.staging/<folder>/exercises: exactly the files
it graded). Each learner graded in the batch's last finished run (grader.course.history) is graded again at that run's
seed and chapters, behind the sandbox as a batch grades, with the overrides (OUT/overrides.csv) and the late
penalty applied as a batch applies them, and compared with what that run recorded: the score (the gradebook's)
and every check's verdict and points (its report.json). The learners that move are printed and written into
OUT/regrade.csv (learner, old_score, new_score, checks_changed, why); nothing else is written. With `apply`
(and a reason) the new grades become a run of the history that carries the reason, the moved learners'
report.json, results.json and report.html are rewritten, and the class outputs are rebuilt from it (grade batch's
rebuild: gradebook.csv, changes.csv, which says "regrade (the reason)", junit.xml, the summary).
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from grader.course.staging import STAGING, folder_name
from grader.model import Report, points_text, rounded_points
from grader.safe_text import for_csv, json_text

if TYPE_CHECKING:
    from grader.course_config import Course

CSV_NAME = "regrade.csv"
COLUMNS = ("learner", "old_score", "new_score", "checks_changed", "why")


class RegradeError(ValueError):
    """OUT holds nothing to regrade (no history, no finished run); the message says what it holds."""


@dataclass
class Moved:
    """One learner compared: their score as the run recorded it and as graded today, the checks whose verdict or
    points changed (in words), and why in one line. `new_score` None: could not be graded again."""

    learner: str
    old_score: float | None
    new_score: float | None
    checks: list[str] = field(default_factory=list)  # stable ids
    why: str = ""

    @property
    def moves(self) -> bool:
        return self.new_score is None or self.new_score != self.old_score or bool(self.checks)


@dataclass
class Regrade:
    """What a regrade found: the run it regraded (its id and data), every learner compared, the learners it could
    not regrade (no stored submission), the overrides that could not apply, today's grader version, and (after
    apply) the run that recorded it."""

    run: int
    run_info: dict
    compared: list[Moved]
    left_out: dict[str, str]
    override_problems: list[str]
    grader: str
    isolation: str
    reports: dict[str, Report] = field(default_factory=dict, repr=False)
    recorded: int | None = None

    @property
    def moved(self) -> list[Moved]:
        return [m for m in self.compared if m.moves]


@dataclass(frozen=True)
class _Task:
    """One learner to grade again (plain data: it travels to a worker process)."""

    learner: str
    root: str
    chapters: tuple[str, ...]
    seed: int
    limits: dict
    sandbox: str
    course: Course | None
    overrides: tuple
    submitted: str
    other_ids: tuple[str, ...]


def _grade(task: _Task) -> tuple[str, Report | None, str]:
    """(learner, their report graded again with overrides and late penalty applied, or None and why not), in a
    worker process: the learner's code behind the boundary grade batch grades behind."""
    from grader.course import batch
    from grader.course import overrides as adjusting

    report = batch._grade_report(Path(task.root), task.learner, list(task.chapters), task.seed, False,
                                 dict(task.limits), task.sandbox, task.course, other_ids=task.other_ids)
    if report.infrastructure:
        return task.learner, None, f"not graded, twice, for a reason outside the learner's code: {report.infrastructure}"
    adjusting.apply(report, list(task.overrides), task.course.late if task.course else None,
                    adjusting.parse_time(task.submitted))
    return task.learner, report, ""


def _report_json(out: Path, learner: str) -> dict | None:
    try:
        data = json.loads((out / folder_name(learner) / "report.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


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
    if old is not None and [a.to_dict() for a in old.all_adjustments()] != [a.to_dict() for a in new.all_adjustments()]:
        said.append("overrides or late penalty changed: " + ("; ".join(a.describe() for a in new.all_adjustments())
                                                             or "none now"))
    return Moved(learner, old_score, new.score, changed, "; ".join(said))


def regrade(out: Path, course: Course | None, *, jobs: int | None = None, sandboxed: bool = True,
            overrides: Path | None = None, limits: dict | None = None,
            progress: Callable[[int, int], None] | None = None) -> Regrade:
    """Grade every learner graded in OUT's last finished run again (today's grader, `course`), at its seed and
    chapters, with `overrides` (default OUT/overrides.csv) and the late penalty, and compare. Writes nothing.
    RegradeError where OUT holds no finished run; grader.course.batch.InfrastructureError where learner code cannot
    run here; grader.course.staging.RosterError for an overrides file that cannot be read."""
    from grader import provenance
    from grader.course import batch
    from grader.course import history as histories

    if not (out / histories.FILE_NAME).is_file():
        raise RegradeError(f"{out} holds no {histories.FILE_NAME}: regrade a folder `grade batch --out` wrote")
    history = histories.History(out / histories.FILE_NAME)
    try:
        run = history.last_finished()
        if run is None:
            raise RegradeError(f"{out / histories.FILE_NAME} has no finished run yet: let `grade batch` finish first")
        info, results = history.run_info(run), history.results(run)
    finally:
        history.close()
    chapters = json.loads(info["chapters"])
    graded = sorted(learner for learner, result in results.items() if result.status == "graded")
    rows, problems = batch.read_overrides(overrides or out / "overrides.csv", graded, chapters)
    isolation = batch.choose_boundary("required" if sandboxed else "off", probe=True).isolation
    tasks, left_out, old = [], {}, {}
    for learner in graded:
        root = out / STAGING / folder_name(learner)
        data = _report_json(out, learner)
        if not (root / "exercises").is_dir() or data is None:
            left_out[learner] = ("its stored submission is gone (OUT/.staging)" if data is not None
                                 else "its report.json cannot be read")
            continue
        old[learner] = Report.from_dict(data)
        manifest = (data.get("batch") or {}).get("manifest") or {}
        tasks.append(_Task(learner, str(root), tuple(chapters), int(info["seed"]), dict(limits or {}),
                           "required" if sandboxed else "off", course,
                           tuple(r for r in rows if r.learner == learner), results[learner].submitted or "",
                           (str(manifest["learner"]),) if manifest.get("learner") else ()))
    compared, reports = [], {}
    with ProcessPoolExecutor(max_workers=max(1, min(jobs or os.cpu_count() or 1, len(tasks) or 1))) as pool:
        for done, (learner, report, why_not) in enumerate(pool.map(_grade, tasks), 1):
            compared.append(compare(learner, results[learner].score, old[learner], report, why_not))
            if report is not None:
                reports[learner] = report
            if progress is not None:
                progress(done, len(tasks))
    return Regrade(run, info, compared, left_out, problems, provenance.grader_version(), isolation, reports)


def csv_text(found: Regrade) -> str:
    """regrade.csv: a row per learner whose grade or any check's verdict would move."""
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    writer.writerow(COLUMNS)
    for moved in found.moved:
        writer.writerow([for_csv(moved.learner), points_text(moved.old_score), points_text(moved.new_score),
                         for_csv(" ".join(moved.checks)), for_csv(moved.why)])
    return buffer.getvalue()


def write_csv(out: Path, found: Regrade) -> Path:
    from grader.course.batch import write_atomically

    path = out / CSV_NAME
    write_atomically(path, csv_text(found))
    return path


def apply(out: Path, found: Regrade, course: Course | None, reason: str, overrides: Path | None = None) -> int:
    """Record the regrade as a run of the history with `reason`: the moved learners' report.json, results.json and
    report.html (where it was written) rewritten, every other learner of the regraded run kept as it was, and the
    class outputs rebuilt from the new run. Returns the run's id."""
    from grader.course import batch
    from grader.course import history as histories
    from grader.render import lms

    chapters = json.loads(found.run_info["chapters"])
    for moved in found.moved:
        report = found.reports.get(moved.learner)
        if report is None:  # could not be graded again: its last grade stays
            continue
        folder = out / folder_name(moved.learner)
        kept = (_report_json(out, moved.learner) or {}).get("batch") or {}
        kept.pop("hash", None)  # the next grade batch grades it again, with whatever grader it has then
        data = {**report.to_dict(), "batch": kept}
        batch.write_atomically(folder / "results.json", lms.gradescope(
            report, hidden=course.hidden if course else frozenset(), heading=[f"Graded as {moved.learner}."],
            notes=[str(w) for w in kept.get("warnings") or []]))
        if (folder / "report.html").is_file():
            from grader.render import html as html_renderer

            batch.write_atomically(folder / "report.html", html_renderer.render(report, draw_here=True))
        batch.write_atomically(folder / "report.json", json_text(data) + "\n")
    history = histories.History(out / histories.FILE_NAME)
    before = history.results(found.run)
    learners = list(before)
    statuses = {learner: result.status for learner, result in before.items()}
    messages = {learner: result.message for learner, result in before.items()}
    collected = batch.ClassOutputs(out, learners, statuses, messages, chapters)
    rows, problems = batch.read_overrides(overrides or out / "overrides.csv", learners, chapters)
    try:
        run = history.start(found.grader, course.current_handout if course else found.run_info["handout"],
                            course.id if course else found.run_info["course"], int(found.run_info["seed"]),
                            chapters, reason=reason)
        batch.rebuild(out, history, run, chapters, collected, isolation=found.isolation, overrides=rows,
                      override_problems=problems, deadline=bool(course and course.late))
    finally:
        collected.close()
        history.close()
    found.recorded = run
    return run
