"""GitHub Classroom's message (grader.render.lms.classroom_data) counts its points in words: 1 point, 2 points."""

from __future__ import annotations

from grader.model import ChapterResult, CheckResult, Report, Status
from grader.render import lms


def _report(max_points: float) -> Report:
    check = CheckResult("range_reading_worked_example", "range_reading", "range_reading(3, 4) is 5", Status.PASS,
                        max_points, max_points)
    return Report("alice", [ChapterResult("ch00", "The range-sensor problem", [check])])


def test_the_classroom_message_says_1_point_and_2_points():
    assert lms.classroom_data(_report(1))["message"].startswith("1/1 point judged here; ")
    assert lms.classroom_data(_report(2))["message"].startswith("2/2 points judged here; ")
