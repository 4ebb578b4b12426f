"""Overrides and the late penalty, applied in one place (grader.core.policy.apply_policy): within each target's points,
in order, and every one visible where the grade is, a waiver too, with its reason and what it did."""

from __future__ import annotations

import copy
from datetime import datetime, timezone

import pytest

from grader.core.policy import Override, Policy, apply_policy
from grader.course_config import Late
from grader.model import ChapterResult, CheckResult, Report, Status

LATE = Late(datetime(2026, 5, 1, tzinfo=timezone.utc), per_day=0.1, cap=0.25)
TWO_DAYS_LATE = datetime(2026, 5, 2, 12, tzinfo=timezone.utc)
ON_TIME = datetime(2026, 4, 30, tzinfo=timezone.utc)


@pytest.fixture
def report() -> Report:
    """Two chapters of code and quiz checks, graded: 30 of 40 points."""
    def check(name: str, points: float, kind: str = "code") -> CheckResult:
        return CheckResult(name, "f", "", Status.PASS if points else Status.FAIL, points, 10, kind=kind)

    return Report("x", [ChapterResult("ch05", "", [check("a", 10), check("quiz_b", 0, "quiz")]),
                        ChapterResult("ch06", "", [check("c", 10), check("d", 10)])])


def _row(target: str, points: float | None = None, factor: float | None = None, line: int = 2) -> Override:
    return Override("x", target, points, factor, f"reason {line}", "bo", f"o.csv, line {line}")


def test_overrides_stay_within_the_points_and_apply_in_order(report):
    rows = [_row("total", points=-1000.0, line=4), _row("ch06/c", points=5.0, line=2), _row("ch06", factor=0.5, line=3),
            _row("ch06/nope", points=1.0, line=5)]
    outcomes = apply_policy(report, Policy(tuple(rows)))
    ch06 = report.chapters[1]
    assert [(o.override.source, o.applied, o.said) for o in outcomes] == [  # checks first, then chapters, the total
        ("o.csv, line 2", True, "+0"),  # the check is at its maximum already
        ("o.csv, line 5", False, "not applied: ch06/nope is not a check graded for x (`grade list --checks` shows "
                                 "the ids)"),
        ("o.csv, line 3", True, "-10"), ("o.csv, line 4", True, "-20")]  # the total is 20 by then, and stays at 0
    assert ch06.score == ch06.raw_score / 2 and report.score == 0 and report.raw_score == 30


def test_the_late_penalty_is_capped_and_a_waiver_is_an_adjustment_with_its_reason(report):
    late = copy.deepcopy(report)
    assert apply_policy(late, Policy((), LATE, datetime(2026, 5, 9, tzinfo=timezone.utc))) == []
    assert late.score == pytest.approx(0.75 * 30)  # capped at 25%
    waived = copy.deepcopy(report)
    [outcome] = apply_policy(waived, Policy((_row("late", factor=0.0, line=6),), LATE, TWO_DAYS_LATE))
    assert waived.score == waived.raw_score == 30
    [adjustment] = waived.all_adjustments()
    assert adjustment.kind == "late" and adjustment.points == 0 and adjustment.source == "o.csv, line 6"
    assert "2 days late" in adjustment.reason and "-20%, waived by override: reason 6" in adjustment.reason
    assert outcome.applied and outcome.said == "waived a late penalty of -6"
    halved = copy.deepcopy(report)
    [outcome] = apply_policy(halved, Policy((_row("late", factor=0.5),), LATE, TWO_DAYS_LATE))
    assert halved.score == 27 and outcome.said == "kept 0.5 of a late penalty of -6: -3"


@pytest.mark.parametrize("submitted, late, due", [
    (ON_TIME, LATE, "none was due: submitted 2026-04-30 00:00 UTC, on time"),
    (None, LATE, "none was due: no trusted submission time"),
    (TWO_DAYS_LATE, None, "none was due: the course has no deadline")])
def test_a_waiver_with_nothing_to_waive_still_leaves_its_trace(report, submitted, late, due):
    [outcome] = apply_policy(report, Policy((_row("late", factor=0.0),), late, submitted))
    [adjustment] = report.all_adjustments()
    assert report.score == 30 and adjustment.points == 0 and adjustment.kind == "late"
    assert adjustment.reason == f"late penalty waived by override: reason 2 ({due})"
    assert outcome.applied and outcome.said == f"nothing to waive ({due})"


def test_applying_again_replaces_what_was_applied(report):
    apply_policy(report, Policy((_row("total", points=-5),), LATE, TWO_DAYS_LATE))
    assert report.score == 30 - 5 - 0.2 * 25
    apply_policy(report, Policy())
    assert report.score == 30 and report.all_adjustments() == []


def test_overrides_and_the_late_penalty_are_applied_in_one_function_only():
    """The one place: grader/core/policy.py defines apply_policy, and nothing else in the grader makes an adjustment
    (an Adjustment(...) or a late share from Late.fraction)."""
    import ast

    from tests.support import REPO

    makers = {}
    for path in sorted((REPO / "grader").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call):
                name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
                if name in ("Adjustment", "fraction"):
                    makers.setdefault(path.relative_to(REPO).as_posix(), set()).add(name)
    assert makers == {"grader/core/policy.py": {"Adjustment", "fraction"}, "grader/model.py": {"Adjustment"}}
