"""overrides.csv: what an instructor changes of a learner's points after grading, and why. Read here; applied by
grader.core.policy.apply_policy, the one place overrides and the late penalty are applied.

`overrides.csv` (beside grade batch's outputs, or --overrides FILE) has one row per change, with the columns
`learner`, `target`, `points` or `factor`, `reason` and `who`:

    learner,target,points,factor,reason,who
    ann,ch06/H_worked_example,2,,regrade request: the sign convention was ambiguous,bo
    carl,ch06,,0.5,academic integrity panel decision 2026-05-12,the instructor
    dee,late,,0,accommodation: extension to Friday,the instructor
    eve,total,-3,,penalty agreed with the learner,bo

`target` is a check (chNN/check_id, its stable id as every output shows it), a chapter (chNN), the total (`total`
or empty), or `late` (the late penalty). A row that cannot be applied is reported with its file and line, and the
others still apply. The file is read on every `grade batch`, so an override stays until its row is removed, and
the history (gradebook.db) keeps every one with what it did.
"""

from __future__ import annotations

import math
from pathlib import Path

from grader.core.policy import Override
from grader.csvtable import TableError, read_table
from grader.render import plural

COLUMNS = ("learner", "target", "points", "factor", "reason", "who")


class OverridesError(ValueError):
    """An overrides file that cannot be read at all (its header, its encoding); the message names the file."""


def read(path: Path, text: str | None = None) -> tuple[list[Override], list[str]]:
    """The overrides in `path` (or in `text`, the file as a run read it) and a message (file and line) for every row
    that cannot be one; no file: nothing. TableError for a file that cannot be read at all."""
    if text is None and not path.is_file():
        return [], []
    overrides, problems = [], []
    for line, row in read_table(path, ("learner", "reason"), text):
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


def in_force(path: Path, learners: list[str], chapters: list[str], text: str | None = None) -> tuple[list[Override],
                                                                                                   list[str]]:
    """The rows of the overrides file at `path` (or its `text`, as a run read it) that can apply to these `learners`
    graded on these `chapters`, and a message (file and line) for each that cannot: an unknown learner, check or
    chapter, more points than its target holds. OverridesError for a file that cannot be read at all."""
    from grader import checks as check_registry

    try:
        rows, problems = read(path, text)
    except TableError as exc:
        raise OverridesError(str(exc)) from None
    known = set(learners)
    usable = []
    for row in rows:
        chapter = row.target.split("/", 1)[0]
        if row.learner not in known:
            problems.append(f"{row.source}: no learner {row.learner!r} in this batch; row not applied")
        elif row.level in ("check", "chapter") and chapter not in chapters:
            problems.append(f"{row.source}: {chapter} is not graded in this batch (--chapters); row not applied")
        elif row.level == "check" and row.target.split("/", 1)[1] not in {c.id for c in
                                                                          check_registry.load(chapter).checks}:
            problems.append(f"{row.source}: {row.target} is not a check of {chapter} (`grade list --checks` shows "
                            "the ids; a quiz question is quiz_<its id>); row not applied")
        elif row.points is not None and abs(row.points) > _most_points(row, chapters):
            problems.append(f"{row.source}: {plural(row.points, 'point')} is more than {row.target} can move "
                            f"(at most {_most_points(row, chapters):g}); row not applied")
        else:
            usable.append(row)
    return usable, problems


def by_learner(rows: list[Override]) -> dict[str, tuple[Override, ...]]:
    """Each learner's rows, in the file's order."""
    found: dict[str, list[Override]] = {}
    for row in rows:
        found.setdefault(row.learner, []).append(row)
    return {learner: tuple(rows) for learner, rows in found.items()}


def _most_points(row: Override, chapters: list[str]) -> float:
    """The most points an override of `row.target` can add or take: its check's, its chapter's code (the quiz's
    questions are not known here: an override of a chapter may also move its quiz, so its quiz's too, at most the
    whole course), or the whole batch's."""
    from grader import checks as check_registry
    from grader.quiz import bank

    def quiz(chapter: str) -> float:
        try:
            return sum(q.points for q in bank.questions(chapter))
        except (OSError, ValueError):
            return 0.0

    if row.level == "check":
        chapter, check_id = row.target.split("/", 1)
        if check_id.startswith("quiz_"):
            return next((q.points for q in bank.questions(chapter) if f"quiz_{q.id}" == check_id), 0.0)
        return next(c.points for c in check_registry.load(chapter).checks if c.id == check_id)
    if row.level == "chapter":
        return check_registry.load(row.target).max_score + quiz(row.target)
    return sum(check_registry.load(c).max_score + quiz(c) for c in chapters)


__all__ = ["COLUMNS", "Override", "OverridesError", "TableError", "by_learner", "in_force", "read"]
