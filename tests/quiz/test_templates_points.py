"""`grade quiz --show` (grader.quiz.templates.show_text) says what each question is worth: 1 point, 2 points."""

from __future__ import annotations

from click.testing import CliRunner

from grader.faces.cli import main
from grader.quiz import bank


def test_show_says_1_point_and_2_points():
    result = CliRunner().invoke(main, ["quiz", "ch06", "--show", "--solutions"])
    assert result.exit_code == 0, result.output
    questions = bank.questions("ch06")
    assert {q.points == 1 for q in questions} == {True, False}  # both are shown
    for q in questions:
        worth = "1 point" if q.points == 1 else f"{q.points:g} points"
        assert f"[{q.id}] ({q.kind}, {worth})" in result.output
    assert "1 points" not in result.output
