"""Tolerances fit the precision the format hints show: every numeric, vector and matrix hint says how
many decimals or significant digits are enough, its examples show no more, the key rounded to that
precision is right for every learner's numbers (and gets no diagnosis), the tolerance is no looser
than that precision needs, and every mismatch message prints the tolerance."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from grader.chapters import CHAPTERS
from grader.judging.compare import tolerance_text
from grader.quiz import bank, grade_quiz
from grader.quiz.judge import judge, right_numbers
from grader.quiz.templates import hint

NUMBERS = [(c.id, q) for c in CHAPTERS for q in bank.questions(c.id) if q.kind in ("numeric", "vector", "matrix")]
LEARNERS = ["reference", "anonymous", "alice", "bob", *(f"learner{i}" for i in range(21))]
PRECISION = re.compile(r"(\d+) (decimals|significant digits) are enough")
EXAMPLE = re.compile(r"`([^`]*)`")


def precision(question) -> tuple[int, str]:
    found = PRECISION.search(hint(question))
    assert found, f"{question.id}: the hint says how precise an answer must be: {hint(question)!r}"
    return int(found.group(1)), found.group(2)


def rounded(value: np.ndarray, digits: int, unit: str) -> np.ndarray:
    """`value` as a learner writes it to the hint's precision."""
    if unit == "decimals":
        return np.round(value, digits)
    return np.vectorize(lambda v: float(f"{v:.{digits}g}"))(value)


@pytest.mark.parametrize("chapter, question", NUMBERS, ids=lambda v: getattr(v, "id", v))
def test_the_key_rounded_to_the_hints_precision_is_right_for_every_learner(chapter, question):
    digits, unit = precision(question)
    key = bank.keys(chapter)[question.id]
    for learner in LEARNERS if question.params else LEARNERS[:1]:
        values = question.values_for(learner, chapter)
        right = key.value_for(chapter, values)
        written = rounded(right_numbers(right, key, values), digits, unit)
        text = json.dumps(written.tolist()) if written.ndim else repr(float(written))
        verdict = judge(question, key, text, right, seed=1, values=values)
        assert verdict.right, (question.id, learner, text, verdict.feedback)
        assert verdict.mistake == ""


@pytest.mark.parametrize("chapter, question", NUMBERS, ids=lambda v: getattr(v, "id", v))
def test_the_hints_examples_show_that_precision_and_the_tolerance_is_no_looser(chapter, question):
    digits, unit = precision(question)
    for example in EXAMPLE.findall(hint(question)):
        for number in re.findall(r"\d+\.\d+|\d+(?:e-?\d+)?", example):
            if unit == "decimals":
                assert len(number.split(".")[1]) <= digits if "." in number else True, (example, digits)
            else:
                assert len(number.replace(".", "").split("e")[0].lstrip("0")) <= digits, (example, digits)
    key = bank.keys(chapter)[question.id]
    if unit == "decimals":
        assert key.atol <= 0.5 * 10.0 ** -digits and key.rtol <= 1e-3, (key.atol, key.rtol)
    else:
        assert key.rtol <= 0.5 * 10.0 ** (1 - digits) and key.atol <= 1e-6, (key.atol, key.rtol)


def test_a_value_right_only_to_fewer_digits_than_the_hint_asks_fails_and_says_the_tolerance(tmp_path):
    question = next(q for q in bank.questions("ch06") if q.id == "H_at_point")
    key = bank.keys("ch06")["H_at_point"]
    right = right_numbers(key.value_for("ch06", question.values_for("alice", "ch06")), key)
    folder = tmp_path / "answers"
    folder.mkdir()
    for digits, passes in ((2, True), (1, False)):
        (folder / "ch06.yaml").write_text(f"H_at_point: {json.dumps(np.round(right, digits).tolist())}\n")
        result = next(r for r in grade_quiz("ch06", folder, "alice", "exercises/answers")[0] if r.function == "H_at_point")
        assert (result.status.value == "pass") == passes, result.message
    assert result.message == ("not within the tolerance of the right value "
                              "(tolerance |got - expected| <= 0.005 + 0.001*|expected| in every entry)")


@pytest.mark.parametrize("chapter, question", NUMBERS, ids=lambda v: getattr(v, "id", v))
def test_every_mismatch_message_prints_its_tolerance(tmp_path, chapter, question):
    key = bank.keys(chapter)[question.id]
    values = question.values_for("alice", chapter)
    wrong = right_numbers(key.value_for(chapter, values), key, values) * 1.7 + 0.3  # no known mistake
    text = json.dumps(wrong.tolist()) if wrong.ndim else repr(float(wrong))
    folder = tmp_path / "answers"
    folder.mkdir()
    (folder / f"{chapter}.yaml").write_text(f"{question.id}: {text}\n")
    result = next(r for r in grade_quiz(chapter, folder, "alice", "exercises/answers")[0] if r.function == question.id)
    assert result.status.value == "fail" and result.mistake == ""
    assert result.message.startswith("not within the tolerance of the right value")
    assert tolerance_text(key.rtol, key.atol) in result.message
