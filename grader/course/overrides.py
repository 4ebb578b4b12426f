"""Overrides and late penalties: what changes a learner's points after grading, and why.

`overrides.csv` (beside grade batch's outputs, or --overrides FILE) has one row per change, with the
columns `learner`, `target`, `points` or `factor`, `reason` and `who`:

    learner,target,points,factor,reason,who
    ann,ch06/H_worked_example,2,,regrade request: the sign convention was ambiguous,bo
    carl,ch06,,0.5,academic integrity panel decision 2026-05-12,the instructor
    dee,late,,0,accommodation: extension to Friday,the instructor
    eve,total,-3,,penalty agreed with the learner,bo

`target` is a check (chNN/check_id, its stable id as every output shows it), a chapter (chNN), the
total (`total` or empty), or `late` (the late penalty). `points` are added (negative ones taken
away); a `factor` multiplies (the late penalty's share, for `late`: 0 waives it). A check stays within
0 and its maximum, a chapter and the total at 0 or more. Rows apply in file order, checks first, then
chapters, the total, and the late penalty last. A row that cannot be applied is reported with its
file and line, and the others still apply. The file is read on every `grade batch`, so an override
stays until its row is removed, and grade batch's history (gradebook.db) keeps every one it applied.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from grader.csvtable import TableError, read_table
from grader.model import Adjustment, Report

COLUMNS = ("learner", "target", "points", "factor", "reason", "who")
_ORDER = {"check": 0, "chapter": 1, "total": 2, "late": 3}


@dataclass(frozen=True)
class Override:
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


def read(path: Path) -> tuple[list[Override], list[str]]:
    """The overrides in `path` and a message (file and line) for every row that cannot be one; no file:
    nothing. TableError for a file that cannot be read at all (its header, its encoding)."""
    if not path.is_file():
        return [], []
    overrides, problems = [], []
    for line, row in read_table(path, ("learner", "reason")):
        where = f"{path.name}, line {line}"
        target = row.get("target", "").strip() or "total"
        points, factor = row.get("points", ""), row.get("factor", "")
        try:
            points_value = float(points) if points else None
            factor_value = float(factor) if factor else None
        except ValueError:
            problems.append(f"{where}: points and factor are numbers (got {points!r}, {factor!r}); row not applied")
            continue
        if any(v is not None and not math.isfinite(v) for v in (points_value, factor_value)):
            problems.append(f"{where}: points and factor are finite numbers (got {points!r}, {factor!r}); row not applied")
            continue
        if factor_value is not None and (factor_value < 0 or (target == "late" and factor_value > 1)):
            problems.append(f"{where}: a factor is 0 or more ({'at most 1 for the late penalty; ' if target == 'late' else ''}"
                            f"got {factor!r}); row not applied")
            continue
        if (points_value is None) == (factor_value is None):
            problems.append(f"{where}: give points or a factor, one of them; row not applied")
            continue
        if not row["learner"]:
            problems.append(f"{where}: no learner; row not applied")
            continue
        if not row["reason"]:
            problems.append(f"{where}: every override needs its reason (the learner reads it); row not applied")
            continue
        if target == "late" and points_value is not None:
            problems.append(f"{where}: the late penalty takes a factor (0 waives it, 0.5 halves it); row not applied")
            continue
        overrides.append(Override(row["learner"], target, points_value, factor_value, row["reason"], row.get("who", ""),
                                  where))
    return overrides, problems


def _changed(value: float, override: Override, high: float | None = None) -> float:
    """The change `override` makes to `value`, kept within 0 and `high`."""
    new = value * override.factor if override.factor is not None else value + override.points
    new = max(0.0, new if high is None else min(high, new))
    return new - value


def apply(report: Report, overrides: list[Override], late=None, submitted: datetime | None = None) -> list[str]:
    """Put on `report` the adjustments its `overrides` (this learner's rows) and the course's late penalty
    (`late`, grader.course_config.Late, for a submission made at `submitted`) make, replacing any it had. Returns
    a message for each override that could not be applied (no such check or chapter here)."""
    for chapter in report.chapters:
        chapter.adjustments = []
    report.adjustments = []
    problems = []
    chapters = {c.chapter: c for c in report.chapters}
    late_factor = 1.0
    for override in sorted(overrides, key=lambda o: _ORDER[o.level]):
        adjustment = dict(reason=override.reason, who=override.who, source=override.source, target=override.target)
        if override.level == "late":
            late_factor *= override.factor
            continue
        if override.level == "check":
            chapter_id, check_id = override.target.split("/", 1)
            chapter = chapters.get(chapter_id)
            check = next((c for c in chapter.checks if c.id == check_id), None) if chapter else None
            if check is None:
                problems.append(f"{override.source}: {override.target} is not a check graded for {override.learner} "
                                "(`grade list --checks` shows the ids); row not applied")
                continue
            current = check.points + sum(a.points for a in chapter.adjustments if a.target == override.target)
            chapter.adjustments.append(Adjustment(points=_changed(current, override, check.max_points),
                                                  check_kind=check.kind, **adjustment))
        elif override.level == "chapter":
            chapter = chapters.get(override.target)
            if chapter is None:
                problems.append(f"{override.source}: {override.target} is not a chapter graded here; row not applied")
                continue
            chapter.adjustments.append(Adjustment(points=_changed(chapter.score, override), **adjustment))
        else:
            report.adjustments.append(Adjustment(points=_changed(report.score, override), **adjustment))
    if late is not None and submitted is not None:
        share, days = late.fraction(submitted)
        share *= late_factor
        if share > 0:
            waived = "" if late_factor == 1 else f", {late_factor:g} of it by override"
            report.adjustments.append(Adjustment(
                target="total", points=-share * report.score, kind="late", source="the course config",
                reason=(f"{days} day{'s' * (days != 1)} late (submitted {_shown(submitted)}, deadline "
                        f"{_shown(late.deadline)}): -{100 * share:g}%{waived}")))
    return problems


def _shown(moment: datetime) -> str:
    return moment.astimezone(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def parse_time(text: str) -> datetime | None:
    """A submission time as rosters and manifests write it (ISO 8601; without a zone, UTC), or None."""
    if not text:
        return None
    try:
        moment = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        return None
    return moment if moment.tzinfo else moment.replace(tzinfo=timezone.utc)


__all__ = ["Override", "TableError", "apply", "read", "parse_time", "COLUMNS"]
