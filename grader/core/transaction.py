"""One transaction grades one submission, for every face: `grade chNN`, --watch, the notebook's grading process, a
batch worker, a Dask task, Gradescope, a regrade and GitHub Classroom all call grade_submission.

It opens a session behind the face's Door (the boundary chosen from one SandboxMode, grader.boundary.choose),
builds the report (grader.core.pipeline.build_report), tries once more behind a door opened afresh when grading
failed for a reason outside the learner's code (Report.infrastructure: never a grade), closes what it opened, and
applies the learner's overrides and late penalty (grader.core.policy.apply_policy). What a face then does with the
report (print it, write it, record it) is its own.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from grader import boundary
from grader.boundary import Limits, SandboxMode
from grader.chapters import BY_ID
from grader.core.pipeline import build_report
from grader.core.policy import Outcome, Policy, apply_policy
from grader.model import ChapterResult, Report

if TYPE_CHECKING:
    from grader.boundary import Boundary, Session
    from grader.core.memo import Memo
    from grader.core.pipeline import Request
    from grader.course_config import Course
    from grader.submission import Submission

NO_CHILD = "no child process could start"


class Door:
    """Where a face's learner code starts: the boundary chosen for `mode` on first use (grader.boundary.choose) and
    kept for the face's sessions (`resident`: a fork server where the system allows), renewed after an
    infrastructure failure. `remember`: the one-off `grade` keeps the sandbox's command line for the next command's
    launcher (grader.boundary.kept); `started`: a child that launcher started already (grader.faces.prestart);
    `pause`: seconds to wait before the second try (a batch's worker lets a failing machine settle)."""

    def __init__(self, mode: SandboxMode | str, *, resident: bool = False, probe: bool = False,
                 secrets: tuple[str, ...] = (), remember: bool = False, turned_off: str = "with --no-sandbox",
                 pause: float = 0.0) -> None:
        self.mode = SandboxMode(mode)
        self.resident, self.probe, self.secrets, self.remember = resident, probe, tuple(secrets), remember
        self.turned_off, self.pause = turned_off, pause
        self.started = None
        self._boundary: Boundary | None = None

    @property
    def boundary(self) -> Boundary:
        """The chosen boundary (BoundaryUnavailable where `mode` cannot be had here)."""
        if self._boundary is None:
            self._boundary = boundary.choose(self.mode.value, resident=self.resident, probe=self.probe,
                                             secrets=self.secrets, remember=self.remember,
                                             turned_off=self.turned_off)
        return self._boundary

    @property
    def isolation(self) -> str:
        """The isolation line: what holds for learner code behind this door."""
        return self.boundary.isolation

    def open(self, submission: Submission, limits: Limits) -> Session:
        """A session for `submission` (its child the one the launcher started, where it started one for this door)."""
        started, self.started = self.started, None
        return self.boundary.open_session(submission, limits, started=started)

    def renew(self) -> None:
        """After grading failed for a reason outside the learner's code: nothing of the old boundary is used again
        (its fork servers stop; the one-off `grade`'s kept sandbox is forgotten, and none is kept from now on)."""
        if self.remember:
            from grader.boundary import kept

            kept.forget()
            self.remember = False
        if self.started is not None:
            self.started.stop(0)
            self.started = None
        self.close()

    def close(self) -> None:
        """Stop what the boundary keeps running (a resident fork server); the next session chooses again."""
        chosen, self._boundary = self._boundary, None
        if chosen is not None:
            chosen.close()


@dataclass
class Graded:
    """A submission graded: its report (adjusted as `policy` says, unless it records an infrastructure failure, which
    is no grade), what each override did, how many tries it took and the isolation line it was graded behind."""

    report: Report
    outcomes: list[Outcome] = field(default_factory=list)
    tries: int = 1
    isolation: str = ""

    @property
    def infrastructure(self) -> str:
        """Why it could not be graded for a reason outside the learner's code ("" when it was graded)."""
        return self.report.infrastructure


def grade_submission(submission: Submission, request: Request, door: Door, policy: Policy = Policy(), *,
                     limits: Limits = Limits(), course: Course | None = None,
                     memo: Memo | Callable[[Session], Memo | None] | None = None,
                     prepare: Callable[[Session], None] | None = None) -> Graded:
    """Grade `submission` as `request` asks, as `course` has it (grader.core.pipeline.build_report), behind `door`,
    with `memo`'s kept verdicts (or those of memo(session)); `prepare(session)` is the face's own work once the first
    session is open (imports to make while the child runs). Tried a second time behind a renewed door when the first
    try failed for a reason outside the learner's code; then `policy` is applied to the report. BoundaryUnavailable
    where the door's mode cannot be had here at all."""
    report = None
    for attempt in (1, 2):
        try:
            session = door.open(submission, limits)
        except OSError as exc:
            report = _not_started(request, f"{NO_CHILD} ({type(exc).__name__}: {exc})")
        else:
            try:
                if prepare is not None and attempt == 1:
                    prepare(session)
                kept = memo(session) if callable(memo) else memo
                report = build_report(session, request, course, kept)
            finally:
                session.close()
            if not report.infrastructure:
                break
        if attempt == 1:
            door.renew()
            time.sleep(door.pause)
    graded = Graded(report, tries=attempt, isolation=door.isolation if not report.infrastructure else "")
    if not report.infrastructure:
        graded.outcomes = apply_policy(report, policy)
    return graded


def _not_started(request: Request, why: str) -> Report:
    """The report of a submission whose learner code could not start at all: no grade, and why."""
    return Report(request.label or "", [ChapterResult(c, BY_ID[c].title) for c in request.chapters],
                  seed=request.seed, infrastructure=why)
