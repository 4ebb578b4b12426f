"""The HTML report (grader.render.html) counts recorded quiz points in words: +1 point, +2 points."""

from __future__ import annotations

from grader.model import ChapterResult, CheckResult, Report, Status
from grader.render import html


def _report(*recorded: float) -> Report:
    checks = [CheckResult(f"quiz_q{i}", "quiz", f"question {i}", Status.RECORDED, 0, points, kind="quiz")
              for i, points in enumerate(recorded)]
    return Report("alice", [ChapterResult("ch06", "The range-bearing measurement Jacobian H", checks)])


def test_recorded_quiz_points_are_1_point_and_2_points():
    assert "(+1 point recorded, graded when you submit)" in html.render(_report(1))
    assert "(+2 points recorded, graded when you submit)" in html.render(_report(1, 1))
    assert "(+1 point recorded" in html.render_fragment(_report(1))
