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


def test_an_expression_is_worth_the_same_as_its_tree_walked_node_by_node_and_few_evaluators_are_kept():
    """evaluate() runs a tree made into nested functions: at every point, the value (or the reason it has none) is
    what walking the tree node by node gives, operation by operation; and however many trees a class's answers make,
    only the last few trees' functions are kept (a worker's memory stays flat)."""
    import ast
    import math
    import operator
    import random

    from grader.quiz import symbolic

    def walked(node, values):  # the definition: each operation's result a finite real float, else Undefined
        if isinstance(node, ast.Expression):
            return walked(node.body, values)
        if isinstance(node, ast.Constant):
            return float(node.value)
        if isinstance(node, ast.Name):
            return values[node.id] if node.id in values else symbolic.CONSTANTS[node.id]
        try:
            if isinstance(node, ast.UnaryOp):
                result = -walked(node.operand, values) if isinstance(node.op, ast.USub) else walked(node.operand, values)
            elif isinstance(node, ast.BinOp):
                operation = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
                             ast.Div: operator.truediv}.get(type(node.op), operator.pow)
                result = operation(walked(node.left, values), walked(node.right, values))
            else:
                result = symbolic.FUNCTIONS[node.func.id][0](*[walked(arg, values) for arg in node.args])
        except ZeroDivisionError:
            raise symbolic.Undefined("division by zero") from None
        except OverflowError:
            raise symbolic.Undefined("too large") from None
        except ValueError:
            raise symbolic.Undefined("outside a function's domain, e.g. sqrt or log of a negative number") from None
        if isinstance(result, complex) or not math.isfinite(result):
            raise symbolic.Undefined("not a finite real number")
        return float(result)

    def outcome(function, tree, point):
        try:
            return function(tree, point)
        except symbolic.Undefined as exc:
            return str(exc)

    draw = random.Random(7)

    def expression(depth):
        if depth == 0 or draw.random() < 0.25:
            return draw.choice(["x", "y", "pi", "e", "0", "2.5", "1e308", "1e-300", "(-1)"])
        if draw.random() < 0.6:
            return f"({expression(depth - 1)} {draw.choice('+-*/')}{'*' * draw.randint(0, 1)} {expression(depth - 1)})"
        name = draw.choice(["sqrt", "sin", "cos", "tan", "atan", "exp", "log", "abs"])
        return f"{name}({expression(depth - 1)})"

    compared = 0
    for _ in range(3000):
        try:
            tree = symbolic.check_text(expression(4), ("x", "y"))
        except symbolic.AnswerError:
            continue
        for _ in range(3):
            point = {"x": draw.uniform(-5, 5), "y": draw.choice([0.0, draw.uniform(-5, 5)])}
            assert outcome(symbolic.evaluate, tree, point) == outcome(walked, tree, point)
            compared += 1
    assert compared > 3000 and len(symbolic._EVALUATORS) <= symbolic._EVALUATORS_MAX
