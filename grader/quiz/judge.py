"""Judge one answer against its key: a verdict with points in [0, 1] of the question's worth."""

from __future__ import annotations

import ast
import math
import re
from dataclasses import dataclass

import numpy as np

from grader.quiz.bank import Key, Question
from grader.quiz.symbolic import (
    MAX_LENGTH,
    AnswerError,
    Undefined,
    check_text,
    equivalent,
    evaluate,
    number,
)


@dataclass
class Judgement:
    fraction: float  # of the question's points
    feedback: str
    right: bool = False


def _letters(value: object, question: Question) -> list[str]:
    if isinstance(value, (list, tuple)):
        items = [str(v) for v in value]
    else:
        items = re.split(r"[\s,;]+", str(value).strip())
    letters = [item.strip().strip(").").lower() for item in items if item.strip()]
    unknown = [letter for letter in letters if letter not in question.options]
    if unknown or not letters:
        shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:37] + "..."
        raise AnswerError(f"choose from {', '.join(question.options)} (got {shown})")
    return letters


def _numbers(value: object) -> list:
    """A flat or nested list of numbers from YAML data or text like '4, 1', '[4, 1]', '(4,1)',
    '4 1', '[[1, 2], [3, 4]]' or rows separated by ';' ('1, 2; 3, 4')."""
    if isinstance(value, (list, tuple)):
        return [_numbers(v) if isinstance(v, (list, tuple)) else number(v) for v in value]
    text = str(value).strip()
    if len(text) > 4 * MAX_LENGTH:
        raise AnswerError(f"the answer is {len(text)} characters long; at most {4 * MAX_LENGTH} are read")
    if ";" in text:  # rows separated by ';'
        return [_numbers(row) for row in text.strip("[]() ").split(";")]
    if text.startswith(("[", "(")):
        tree = check_text(text, (), lists=True).body  # whitelisted before anything else
        return _numbers_of_node(tree)
    return [number(part) for part in text.split(",") if part.strip()] if "," in text else \
        [number(part) for part in text.split()]


def _numbers_of_node(node: ast.AST) -> list | float:
    if isinstance(node, (ast.List, ast.Tuple)):
        return [_numbers_of_node(item) for item in node.elts]
    try:
        return evaluate(node, {})
    except Undefined as exc:
        raise AnswerError(f"{ast.unparse(node)} has no finite real value ({exc})") from None


def _array(value: object, shape: tuple[int, ...]) -> np.ndarray:
    numbers = _numbers(value)
    try:
        array = np.array(numbers, dtype=float)
    except ValueError:
        raise AnswerError("rows of different lengths") from None
    if shape and array.shape != shape:
        raise AnswerError(f"expected {'x'.join(map(str, shape))} numbers, got shape {array.shape}")
    return array


def _transformed(key: np.ndarray, transform: str) -> np.ndarray | None:
    if transform == "transpose":
        return key.T if key.ndim == 2 and key.shape[0] == key.shape[1] and not np.allclose(key, key.T) else None
    if transform == "negate":
        return -key
    if transform == "degrees":
        return np.degrees(key)
    if transform == "reciprocal":
        return 1.0 / key
    raise ValueError(f"unknown transform {transform}")


def judge(question: Question, key: Key, value: object, right_value: object, seed: int) -> Judgement:
    """Raises AnswerError when the answer cannot be read."""
    kind = question.kind
    if kind == "choice":
        letters = _letters(value, question)
        if len(letters) != 1:
            raise AnswerError("choose exactly one option")
        if letters[0] == str(right_value).lower():
            return Judgement(1.0, key.explanation, True)
        return Judgement(0.0, key.feedback.get(letters[0], "not this one"))
    if kind == "multi":
        picked = set(_letters(value, question))
        right = {str(v).lower() for v in right_value}
        if picked == set(question.options):
            return Judgement(0.0, "selecting every option earns nothing: choose the true statements")
        hits, misses = len(picked & right), len(picked - right)
        fraction = max(0.0, (hits - misses) / len(right))
        notes = [f"{letter}) {key.feedback[letter]}" for letter in sorted(picked - right) if letter in key.feedback]
        missed = sorted(right - picked)
        if missed:
            notes.append(f"{len(missed)} true statement(s) not selected")
        return Judgement(fraction, "; ".join(notes) or key.explanation, picked == right)
    if kind in ("numeric", "vector", "matrix"):
        if kind == "numeric" and isinstance(value, (list, dict)):
            raise AnswerError("expected one number, got a list")
        got = np.array(number(value)) if kind == "numeric" else _array(value, question.shape)
        want = np.asarray(right_value, dtype=float)
        if got.shape != want.shape:
            raise AnswerError(f"expected {want.size} number(s), got {got.size}")
        close = bool(np.all(np.abs(got - want) <= key.atol + key.rtol * np.abs(want)))
        if close:
            return Judgement(1.0, key.explanation, True)
        for wrong in key.wrong:
            candidate = (_transformed(want, wrong["transform"]) if "transform" in wrong
                         else np.asarray(wrong["answer"], dtype=float))
            if candidate is not None and candidate.shape == got.shape and \
                    np.all(np.abs(got - candidate) <= key.atol + key.rtol * np.abs(candidate)):
                return Judgement(0.0, wrong["feedback"])
        return Judgement(0.0, "not within the tolerance of the right value")
    if kind == "symbolic":
        if isinstance(value, (list, dict)):
            raise AnswerError("expected one expression, got a list")
        text = str(value)
        if equivalent(text, str(right_value), question.symbols, question.domain, seed):
            return Judgement(1.0, key.explanation, True)
        for wrong in key.wrong:
            if equivalent(text, str(wrong["answer"]), question.symbols, question.domain, seed):
                return Judgement(0.0, wrong["feedback"])
        return Judgement(0.0, "not equivalent to the right expression")
    raise AnswerError(f"unknown question kind {kind}")


def fmt_value(value: object) -> object:
    """A right answer as plain data for the report (shown only once the learner got it right)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, float) and math.isfinite(value):
        return value
    return value
