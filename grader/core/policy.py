"""What changes a learner's points after grading, and why: the instructor's overrides and the course's late penalty,
applied here and nowhere else (apply_policy), by every face that grades a submission for the record (a batch, its
regrade, Gradescope).

An override (a row of overrides.csv, grader.course.overrides) targets a check (chNN/check_id, its stable id as every
output shows it), a chapter (chNN), the total (`total`) or the late penalty (`late`). `points` are added (negative
ones taken away); a `factor` multiplies (the late penalty's share, for `late`: 0 waives it). A check stays within 0
and its maximum, a chapter and the total at 0 or more. They apply in order: checks first, then chapters, the total,
and the late penalty last. Every override leaves a trace: an adjustment on the report (a waiver too, at 0 points,
with its reason), and an Outcome saying what it did, for the history.

The submission time that decides the penalty comes from a source the learner cannot write (an LMS's time, a
roster's; a learner's own manifest only where the course accepts it): choosing it is the caller's.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timezone
from typing import TYPE_CHECKING

from grader.model import Adjustment, Report

if TYPE_CHECKING:
    from grader.course_config import Late

_ORDER = {"check": 0, "chapter": 1, "total": 2, "late": 3}


@dataclass(frozen=True)
class Override:
    """One row of overrides.csv: whose points it changes, what (`target`), how (`points` or `factor`), why, by whom,
    and where it was read."""

    learner: str
    target: str  # "ch06/H_worked_example", "ch06", "total" or "late"
    points: float | None
    factor: float | None
    reason: str
    who: str
    source: str  # "overrides.csv, line 3"

    @property
    def level(self) -> str:
        if self.target == "late":
            return "late"
        if "/" in self.target:
            return "check"
        return "chapter" if self.target.startswith("ch") else "total"

    def key(self) -> tuple:
        """What identifies it in the history: who it is for, what it changes, how and why."""
        return (self.learner, self.target, self.points, self.factor, self.reason, self.who)


@dataclass(frozen=True)
class Policy:
    """What one learner's grade is adjusted by: their overrides (in the file's order), the course's late penalty and
    the submission time that decides it (None: no trusted time, so no penalty). Policy() adjusts nothing."""

    overrides: tuple[Override, ...] = ()
    late: Late | None = None
    submitted: datetime | None = None


@dataclass(frozen=True)
class Outcome:
    """What one override did to one report: `applied` or not, and in words ("+2", "waived a late penalty of
    -20.3", "not applied: ...")."""

    override: Override
    applied: bool
    said: str


def apply_policy(report: Report, policy: Policy) -> list[Outcome]:
    """Put on `report` the adjustments `policy` makes, replacing any it had; what each override did, in order."""
    for chapter in report.chapters:
        chapter.adjustments = []
    report.adjustments = []
    outcomes = []
    chapters = {c.chapter: c for c in report.chapters}
    waivers = []
    for override in sorted(policy.overrides, key=lambda o: _ORDER[o.level]):
        if override.level == "late":
            waivers.append(override)
            continue
        adjustment = dict(reason=override.reason, who=override.who, source=override.source, target=override.target)
        if override.level == "check":
            chapter_id, check_id = override.target.split("/", 1)
            chapter = chapters.get(chapter_id)
            check = next((c for c in chapter.checks if c.id == check_id), None) if chapter else None
            if check is None:
                outcomes.append(Outcome(override, False, f"not applied: {override.target} is not a check graded for "
                                                         f"{override.learner} (`grade list --checks` shows the ids)"))
                continue
            current = check.points + sum(a.points for a in chapter.adjustments if a.target == override.target)
            made = Adjustment(points=_changed(current, override, check.max_points), check_kind=check.kind, **adjustment)
            chapter.adjustments.append(made)
        elif override.level == "chapter":
            chapter = chapters.get(override.target)
            if chapter is None:
                outcomes.append(Outcome(override, False, f"not applied: {override.target} is not a chapter graded "
                                                         f"for {override.learner}"))
                continue
            made = Adjustment(points=_changed(chapter.score, override), **adjustment)
            chapter.adjustments.append(made)
        else:
            made = Adjustment(points=_changed(report.score, override), **adjustment)
            report.adjustments.append(made)
        outcomes.append(Outcome(override, True, f"{made.points:+g}"))
    outcomes += _late_penalty(report, policy, waivers)
    return outcomes


def _late_penalty(report: Report, policy: Policy, waivers: list[Override]) -> list[Outcome]:
    """The late penalty as the last adjustment, with the waivers (`late` overrides) that scale it; a waiver with
    nothing to waive is an adjustment of 0 points all the same, so that it is seen where the grade is."""
    factor = 1.0
    for waiver in waivers:
        factor *= waiver.factor
    share, days = policy.late.fraction(policy.submitted) if policy.late and policy.submitted else (0.0, 0)
    by = ""
    if waivers:
        last = waivers[-1]
        by = "; ".join(w.reason for w in waivers)
        origin = dict(who=last.who, source="; ".join(w.source for w in waivers))
    else:
        origin = dict(source="the course config")
    if share > 0:
        due = share * report.score
        late = (f"{days} day{'s' * (days != 1)} late (submitted {_shown(policy.submitted)}, deadline "
                f"{_shown(policy.late.deadline)}): -{100 * share:g}%")
        if factor == 0:
            reason = f"{late}, waived by override: {by}"
        elif factor != 1:
            reason = f"{late}, {factor:g} of it by override: {by}"
        else:
            reason = late
        made = Adjustment(target="total", points=-factor * due, kind="late", reason=reason, **origin)
        report.adjustments.append(made)
        said = (f"waived a late penalty of {-due:+g}" if factor == 0 else
                f"kept {factor:g} of a late penalty of {-due:+g}: {made.points:+g}")
        return [Outcome(w, True, said) for w in waivers]
    if not waivers:
        return []
    none_due = ("none was due: no trusted submission time" if policy.late and policy.submitted is None else
                "none was due: the course has no deadline" if policy.late is None else
                f"none was due: submitted {_shown(policy.submitted)}, on time")
    report.adjustments.append(Adjustment(target="total", points=0.0, kind="late",
                                         reason=f"late penalty waived by override: {by} ({none_due})", **origin))
    return [Outcome(w, True, f"nothing to waive ({none_due})") for w in waivers]


def _changed(value: float, override: Override, high: float | None = None) -> float:
    """The change `override` makes to `value`, kept within 0 and `high`."""
    new = value * override.factor if override.factor is not None else value + override.points
    new = max(0.0, new if high is None else min(high, new))
    return new - value


def _shown(moment: datetime) -> str:
    return moment.astimezone(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def parse_time(text: str | None) -> datetime | None:
    """A submission time as rosters, manifests and LMSs write it (ISO 8601; without a zone, UTC), or None."""
    if not text:
        return None
    try:
        moment = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        return None
    return moment if moment.tzinfo else moment.replace(tzinfo=timezone.utc)
