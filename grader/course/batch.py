"""Batch grading of a folder of submissions: survey, stage, grade in parallel, record, rebuild every output.

Each submission (a folder or a .zip, holding exercises/ or the chapter files directly) is read or safely
extracted, its files kept as one record in OUT/.staging/.records/<folder>.zip (grader.course.staging), and graded
by a worker process (of this
machine's pool, grader.course.workers.LocalPool, or of a Dask cluster, grader.course.cluster) through the one
transaction (grader.core.transaction.grade_submission); the worker returns plain data and this process alone
records it in the history (OUT/gradebook.db, grader.course.history) and writes the learner's files, atomically,
into OUT/<folder>/, where <folder> is the learner's id kept as given where it is plain and percent-encoded
otherwise (folder_name): no id can name a class output, a hidden folder or a path outside OUT.

A learner whose files, grader and judging settings are those of the report the history keeps is not graded again:
that report is adjusted by today's overrides and late penalty (grader.core.policy.apply_policy, as a worker does),
and its files are written again only where what they show changed. The class outputs are rebuilt from the history
at the end (grader.course.outputs.rebuild), so an interrupted run loses nothing graded.

An infrastructure failure (the sandbox or the child process could not start, for no reason of the learner's) is
never a grade: the batch does not start when a probe of the sandbox fails, and a learner whose report says so is
tried once more, then listed as `error` with empty score cells and graded again by the next run.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from grader import provenance
from grader.boundary import SandboxMode
from grader.chapters import CHAPTERS
from grader.core.policy import apply_policy
from grader.course import history as histories
from grader.course import outputs
from grader.course.overrides import OverridesError, by_learner, in_force
from grader.course.settings import RunSettings, Source, differences
from grader.course.staging import RosterError, Skipped, Unmatched, survey
from grader.course.workers import Grading, InfrastructureError, LocalPool, Outcome, collecting_as_a_batch
from grader.model import LearnerResult, Report

if TYPE_CHECKING:
    from grader.course_config import Course

__all__ = ["Batch", "InfrastructureError", "NoSubmissions", "OverridesError", "RosterError", "run_batch"]


class NoSubmissions(ValueError):
    """The submissions folder holds nothing to grade (the message says what it holds instead)."""


@dataclass
class Batch:
    """What a batch did, for the end of its command: per learner its status (graded, unchanged, unreadable, error)
    and message, what was skipped, flagged, moved since the last finished run (and whether there was one), the
    isolation line, the roster's disagreements with the folder, the overrides that could not apply, similar pairs
    and notes for the instructor."""

    statuses: dict[str, str]
    messages: dict[str, str]
    seconds: float
    skipped: list[Skipped]
    isolation: str
    unmatched: list[Unmatched] = field(default_factory=list)
    flagged: dict[str, list[str]] = field(default_factory=dict)
    changes: list[tuple] = field(default_factory=list)
    first_run: bool = True
    override_problems: list[str] = field(default_factory=list)
    similar: list = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def counts(self) -> dict[str, int]:
        found: dict[str, int] = {}
        for status in self.statuses.values():
            found[status] = found.get(status, 0) + 1
        return found

    @property
    def graded_now(self) -> int:
        return sum(status == "graded" for status in self.statuses.values())

    @property
    def complete(self) -> bool:
        """Every submission graded (now or before), none skipped for its id, and every roster row's learner graded (a
        submission no row names is graded under its own name, and listed)."""
        return (all(s in ("graded", "unchanged") for s in self.statuses.values())
                and not any(entry.submission for entry in self.skipped)
                and not any(u.kind == "row" for u in self.unmatched))


def run_batch(submissions: Path, out: Path, *, chapters: list[str] | None = None, roster: Path | None = None,
              jobs: int | None = None, seed: int, seed_from: str = "the course file", html: bool = True,
              plots: bool = False, limits: dict | None = None, progress: Callable | None = None, sandboxed: bool = True,
              hidden: frozenset[str] = frozenset(), lms_layouts: tuple[str, ...] = (), course: Course | None = None,
              overrides: Path | None = None, similarity: bool = False, announce: Callable[[str], None] | None = None,
              pool=None) -> Batch:
    """Grade every submission in `submissions` into `out` and rebuild every class output.
    NoSubmissions (and nothing written) when the folder holds nothing to grade; InfrastructureError when a child
    interpreter does not start here; RosterError for a roster, OverridesError for an overrides file that cannot be
    read. `sandboxed=False` grades without bubblewrap (--no-sandbox); `hidden` are the course's hidden check ids
    (results.json shows them after grades are published); `lms_layouts` ("canvas", "moodle") adds those gradebooks;
    `course` (grader.course_config.Course) leaves out the checks it switches off and gives the late penalty and the
    current handout; `overrides` is the overrides file (default OUT/overrides.csv); `similarity` ranks pairs of
    learners by the similarity of their code (grader.course.similarity); `announce` is given the isolation line
    once the boundary is chosen, before anyone is graded; `pool` grades the learners (default: LocalPool(jobs),
    processes on this machine; grader.course.cluster.ClusterPool grades on a Dask cluster), and whatever it grades
    on, this process alone writes into `out`. Every learner's result goes into OUT/gradebook.db as soon as it is
    graded, once (a result that arrives twice is recorded once)."""
    chapters = chapters or [c.id for c in CHAPTERS]
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs must be at least 1, not {jobs}")
    found = survey(submissions, roster)
    if not found.entries:
        what = "; ".join(f"{s.name}: {s.reason}" for s in found.skipped[:5])
        raise NoSubmissions(f"{submissions} holds no submission to grade (a folder or .zip file per learner)"
                            + (f"; it holds only what is skipped: {what}" if what else ": it is empty"))
    learners = [e.learner for e in found.entries]
    overrides_path = overrides or out / "overrides.csv"
    rows, override_problems = in_force(overrides_path, learners, chapters)
    sandbox = (SandboxMode.REQUIRED if sandboxed else SandboxMode.OFF).value
    limits = limits or {}
    settings = RunSettings(tuple(chapters), seed, seed_from, _course_source(course), Source.read(
        overrides_path if overrides_path.is_file() else None), Source.read(roster),
        course.current_handout if course else None, tuple(lms_layouts), html, plots,
        float(limits.get("learner_seconds", 60.0)), sandbox, provenance.grader_version())
    pool = pool or LocalPool(jobs)
    isolation = pool.isolation(sandbox)
    if announce is not None:
        announce(isolation)
    _draw_meanwhile(len(found.entries))
    out.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    grading = Grading(tuple(chapters), seed, html, plots, limits, sandbox, frozenset(hidden), course)
    with collecting_as_a_batch(), histories.History(out / histories.FILE_NAME) as history:
        last = history.last_finished()
        before = history.settings(last) if last is not None else None
        notes = ([f"this run differs from run {last}: {difference}" for difference in differences(before, settings)]
                 if before is not None else [])
        kept, latest = history.before()
        run = history.start(settings, course.id if course else None)
        recorder = Recorder(out, history, run, grading, kept, latest)
        collected = outputs.ClassOutputs(out, history, run, learners, chapters)
        try:
            previous = {learner: result.content_hash for learner, result in kept.items()}
            for done, outcome in enumerate(pool.grade(found.entries, out, grading, by_learner(rows), previous), 1):
                if outcome.learner in recorder.statuses:  # arrived twice (a task run again elsewhere): recorded once
                    continue
                collected.arrived(*recorder.record(outcome))
                if progress:
                    progress(done, len(found.entries), time.monotonic() - started)
            rebuilt = outputs.rebuild(
                out, history, run, settings, collected,
                overrides=outputs.override_rows(rows, recorder.outcomes, recorder.graded()),
                notes=override_problems + notes, skipped=found.skipped, isolation=isolation,
                roster={"file": roster.name, "unmatched": [u.to_dict() for u in found.unmatched],
                        "said": [u.describe(roster.name) for u in found.unmatched]} if roster else {},
                similarity=similarity)
        finally:
            collected.close()
    return Batch(recorder.statuses, recorder.messages, time.monotonic() - started, found.skipped, isolation,
                 found.unmatched, rebuilt.flagged, rebuilt.changes, rebuilt.first_run, override_problems,
                 rebuilt.similar, notes + rebuilt.notes)


class Recorder:
    """The coordinator's side of each learner's outcome: its result and report recorded in the history, its files
    written into OUT (before the record: a result recorded is a result shown), and what each override did."""

    def __init__(self, out: Path, history: histories.History, run: int, grading: Grading,
                 kept: dict[str, LearnerResult], latest: dict[str, LearnerResult]) -> None:
        self.out, self.history, self.run, self.grading = out, history, run, grading
        self.kept, self.latest = kept, latest  # each learner's last report kept; their last line, which files show
        self.statuses: dict[str, str] = {}
        self.messages: dict[str, str] = {}
        self.outcomes: dict[tuple[str, str], str] = {}  # (learner, override source) -> what it did

    def graded(self) -> set[str]:
        return {learner for learner, status in self.statuses.items() if status in ("graded", "unchanged")}

    def record(self, outcome: Outcome) -> tuple[LearnerResult, Report | None]:
        """Record one learner's outcome; its result and report (None: not graded) for the class outputs."""
        learner = outcome.learner
        self.statuses[learner], self.messages[learner] = outcome.status, outcome.message
        report, files = None, outcome.files
        if outcome.status == "graded":
            report = outcome.report
            facts = outputs.LearnerFacts.of(outcome.staged, report, outcome.extra)
            result = facts.result(report)
            result.report = outcome.kept[0]
            self.outcomes.update({(learner, source): said for source, _, said in outcome.outcomes})
            if not files:
                files = outputs.learner_files(report, facts, self.grading)
        elif outcome.status == "unchanged":
            report, result, files = self._adjusted(outcome)
        else:  # not graded: what staging found, where it got that far
            facts = outputs.LearnerFacts.of(outcome.staged) if outcome.staged else outputs.LearnerFacts(learner)
            result = facts.result(None, outcome.status, outcome.message)
        try:
            outputs.write_learner_files(self.out, learner, files)
        except OSError as exc:
            self.statuses[learner] = "error"
            self.messages[learner] = f"its files could not be written: {exc}"
            result, report = LearnerResult(learner, "error", self.messages[learner]), None
            self.history.record(self.run, result)
            return result, None
        self.history.record(self.run, result, kept=outcome.kept if outcome.status == "graded" else None)
        return result, report

    def _adjusted(self, outcome: Outcome) -> tuple[Report, LearnerResult, dict]:
        """An unchanged learner: the report the history keeps, adjusted by today's overrides and late penalty, and
        its files where what they show changed."""
        learner, staged = outcome.learner, outcome.staged
        kept = self.kept[learner]
        report = self.history.judged(kept.report)
        said = apply_policy(report, staged.policy(self.grading.course))
        self.outcomes.update({(learner, o.override.source): o.said for o in said})
        staged.seconds = kept.seconds or 0.0  # the grading it reuses
        facts = outputs.LearnerFacts.of(staged, report)
        result = facts.result(report)
        result.report = kept.report
        alike = outputs.shown_alike(self.latest.get(learner), result)
        return report, result, {} if alike else outputs.learner_files(report, facts, self.grading)


def _course_source(course: Course | None) -> Source:
    """The course file a run reads (none for the defaults)."""
    if course is None or not course.source or not Path(course.source).is_file():
        return Source()
    return Source.read(Path(course.source))


def _draw_meanwhile(count: int) -> None:
    """The class summary's figures are drawn at the end for a class large enough to have them: matplotlib's import
    (about 0.4 s) runs meanwhile in a drawing process, forked now where that is safe (no thread yet: not beside a
    cluster's client), at a low priority; numpy, which this process imports for the statistics, is shared with it."""
    from grader.course import statistics

    if count >= statistics.RELIABLE_LEARNERS:
        from grader.render import drawer

        drawer.start()


def progress_bar(stream=sys.stderr):
    """A one-line progress bar with ETA on a terminal; nothing otherwise."""
    if not stream.isatty():
        return None

    def show(done: int, total: int, elapsed: float) -> None:
        rate = done / elapsed if elapsed > 0 else 0
        eta = (total - done) / rate if rate > 0 else 0
        width = 30
        filled = int(width * done / max(total, 1))
        stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total}  {rate:.1f}/s  ETA {eta:4.0f} s")
        if done == total:
            stream.write("\n")
        stream.flush()

    return show
