"""Read one answer in its question's terms (read_answer: no key, no sympy) and judge it against its
key (judge: a verdict with points in [0, 1] of the question's worth).

Letters are read as the learner saw them (the question's lettering for that learner) and judged as
the bank's canonical letters, in which keys and feedback are written."""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass

import numpy as np

from grader.quiz.bank import Key, Question
from grader.quiz.symbolic import (
    MAX_LENGTH,
    SIMPLIFY_SECONDS,
    AnswerError,
    Simplifier,
    Undefined,
    check_text,
    equivalent,
    evaluate,
    number,
)

UNDECIDED = (f"could not be decided in time: whether this expression equals the right one took sympy longer "
             f"than {SIMPLIFY_SECONDS:g} s to check, or more than it could; write it in a simpler form")


@dataclass
class Judgement:
    fraction: float  # of the question's points
    feedback: str
    right: bool = False
    undecided: bool = False  # sympy had to decide and could not in time (then fraction is 0)
    out_of_time: bool = False  # ... because the learner's deadline came first


def _letters(value: object, lettering: dict[str, str]) -> list[str]:
    """The letters of an answer as shown to the learner (keys of `lettering`), in the order written."""
    if isinstance(value, (list, tuple)):
        items = [str(v) for v in value]
    else:
        items = re.split(r"[\s,;]+", str(value).strip())
    letters = [item.strip().strip(").").lower() for item in items if item.strip()]
    unknown = [letter for letter in letters if letter not in lettering]
    if unknown or not letters:
        shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:37] + "..."
        raise AnswerError(f"choose from {', '.join(lettering)} (got {shown})")
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


def identity_lettering(question: Question) -> dict[str, str]:
    """The bank's own letters: each shown letter is its canonical letter."""
    return {letter: letter for letter in question.options}


def read_answer(question: Question, value: object, lettering: dict[str, str] | None = None) -> object:
    """The answer in the question's terms, needing neither its key nor sympy: the canonical letters
    (choice: one; multi: a set) of the options the learner picked by their shown letters, a float
    array of the question's shape (numeric, vector, matrix), or the whitelisted expression text in
    the question's symbols. AnswerError says why an answer cannot be read."""
    kind = question.kind
    if kind in ("choice", "multi"):
        lettering = lettering or identity_lettering(question)
        letters = _letters(value, lettering)
        if kind == "multi":
            return {lettering[letter] for letter in letters}
        if len(letters) != 1:
            raise AnswerError("choose exactly one option")
        return lettering[letters[0]]
    if kind == "numeric":
        if isinstance(value, (list, dict)):
            raise AnswerError("expected one number, got a list")
        return np.array(number(value))
    if kind in ("vector", "matrix"):
        return _array(value, question.shape)
    if kind == "symbolic":
        if isinstance(value, (list, dict)):
            raise AnswerError("expected one expression, got a list")
        check_text(str(value), question.symbols)
        return str(value)
    raise AnswerError(f"unknown question kind {kind}")


def judge(question: Question, key: Key, value: object, right_value: object, seed: int,
          lettering: dict[str, str] | None = None, deadline: float | None = None) -> Judgement:
    """The verdict on `value` (letters as shown through `lettering`, default the bank's own) against
    `right_value`; feedback of a wrong option names it by its shown letter. AnswerError when the
    answer cannot be read. A symbolic answer that sympy must decide is decided in a separate process
    within SIMPLIFY_SECONDS and before `deadline` (time.monotonic()), else `undecided`."""
    lettering = lettering or identity_lettering(question)
    got = read_answer(question, value, lettering)
    kind = question.kind
    if kind == "choice":
        if got == str(right_value).lower():
            return Judgement(1.0, key.explanation, True)
        return Judgement(0.0, key.feedback.get(got, "not this one"))
    if kind == "multi":
        right = {str(v).lower() for v in right_value}
        if got == set(question.options):
            return Judgement(0.0, "selecting every option earns nothing: choose the true statements")
        hits, misses = len(got & right), len(got - right)
        fraction = max(0.0, (hits - misses) / len(right))
        notes = [f"{shown}) {key.feedback[canonical]}" for shown, canonical in lettering.items()
                 if canonical in got - right and canonical in key.feedback]
        missed = right - got
        if missed:
            notes.append(f"{len(missed)} true statement(s) not selected")
        return Judgement(fraction, "; ".join(notes) or key.explanation, got == right)
    if kind in ("numeric", "vector", "matrix"):
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
    with Simplifier(deadline) as simplifier:  # a process only if sympy must decide
        same = equivalent(got, str(right_value), question.symbols, question.domain, seed, simplifier)
        if same:
            return Judgement(1.0, key.explanation, True)
        if same is None:
            return Judgement(0.0, UNDECIDED, undecided=True, out_of_time=simplifier.out_of_time)
        for wrong in key.wrong:
            if equivalent(got, str(wrong["answer"]), question.symbols, question.domain, seed, simplifier):
                return Judgement(0.0, wrong["feedback"])
    return Judgement(0.0, "not equivalent to the right expression")


def shown_key(question: Question, right_value: object, lettering: dict[str, str]) -> object:
    """A right answer as the learner sees it: the shown letter(s) of the right option(s)."""
    if question.kind not in ("choice", "multi"):
        return right_value
    shown = {canonical: letter for letter, canonical in lettering.items()}
    if question.kind == "choice":
        return shown[str(right_value).lower()]
    return sorted(shown[str(v).lower()] for v in right_value)


def fmt_value(value: object) -> object:
    """A right answer as plain data for the report (shown only once the learner got it right)."""
    return value.tolist() if isinstance(value, np.ndarray) else value
