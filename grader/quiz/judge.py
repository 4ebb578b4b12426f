"""Read one answer in its question's terms (read_answer: no key, no sympy) and judge it against its
key (judge: a verdict with points in [0, 1] of the question's worth).

Letters are read as the learner saw them (the question's lettering for that learner) and judged as
the bank's canonical letters, in which keys and feedback are written."""

from __future__ import annotations

import ast
import dataclasses
import re
from dataclasses import dataclass

import numpy as np

from grader.judging.compare import tolerance_text
from grader.quiz.bank import Key, Question
from grader.quiz.mistakes import (
    expression_mistake,
    learner_names,
    numbers,
    numbers_mistake,
)
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
    substitute,
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
    mistake: str = ""  # the name of the known mistake a wrong answer matches (grader.quiz.mistakes)


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


def identity_lettering(question: Question) -> dict[str, str]:
    """The bank's own letters: each shown letter is its canonical letter."""
    return {letter: letter for letter in question.options}


def _one_value(question: Question, value: object, text: str, what: str) -> None:
    """AnswerError unless `value` is one value: a list here is mostly YAML's reading of `- y/...`."""
    if isinstance(value, dict):
        raise AnswerError(f"expected {what}, got a mapping")
    if not isinstance(value, list):
        return
    written = " ".join(text.split())
    if written.startswith("-") and len(value) == 1:
        raise AnswerError(f"YAML reads an answer that starts with '- ' as a list: put it in quotes, "
                          f"e.g. {question.id}: \"{written}\"")
    raise AnswerError(f"expected {what}, got a list")


def read_answer(question: Question, value: object, lettering: dict[str, str] | None = None,
                text: str = "") -> object:
    """The answer in the question's terms, needing neither its key nor sympy: the canonical letters
    (choice: one; multi: a set) of the options the learner picked by their shown letters, a float
    array of the question's shape (numeric, vector, matrix), or the whitelisted expression text in
    the question's symbols (and derived symbols). `text` is the answer as written in the file.
    AnswerError says why an answer cannot be read."""
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
        _one_value(question, value, text, "one number")
        return np.array(number(value))
    if kind in ("vector", "matrix"):
        return _array(value, question.shape)
    if kind == "symbolic":
        _one_value(question, value, text, "one expression")
        check_text(str(value), question.symbols + tuple(question.derived))
        return str(value)
    raise AnswerError(f"unknown question kind {kind}")


def answer_terms(question: Question, value: object, lettering: dict[str, str], text: str,
                 values: dict[str, float]) -> dict:
    """A judged answer in the quiz's own terms, kept with its verdict for the class summary: the canonical
    options a choice answer names (the letters are each learner's own), or a symbolic answer's form (as
    written, without its spacing, x^2 and x**2 alike, each of the learner's own numbers shown as its name:
    -(y-2.3)/... as -(y-<b>)/...), so that answers of one form count together; {} for other kinds."""
    if question.kind in ("choice", "multi"):
        try:
            chosen = read_answer(question, value, lettering, text)
        except AnswerError:
            return {}
        return {"options": sorted({chosen} if isinstance(chosen, str) else chosen)}
    if question.kind != "symbolic" or not isinstance(text, str):
        return {}
    form = re.sub(r"\s+", "", text).replace("**", "^")
    for name, its_value in sorted(values.items(), key=lambda kv: -len(f"{kv[1]:g}")):
        form = re.sub(rf"(?<![\d.^]){re.escape(f'{its_value:g}')}(?![\d.])", f"<{name}>", form)
    return {"form": form}


def right_numbers(right_value: object, key: Key, values: dict[str, float] | None = None) -> np.ndarray:
    """The right answer of a numeric, vector or matrix question as floats (a stored key may hold
    expressions such as sqrt(3)/2 or ones in the question's numbers)."""
    return numbers(right_value, learner_names(key, values or {}))


def right_answer(question: Question, key: Key, right_value: object, values: dict[str, float] | None = None) -> object:
    """The right answer in the question's terms: floats for a numeric, vector or matrix question; for a
    symbolic one, the key's expression with the learner's numbers (`values`) for the question's
    parameters."""
    if question.kind in ("numeric", "vector", "matrix"):
        return right_numbers(right_value, key, values)
    if question.kind == "symbolic":
        return substitute(str(right_value), values or {}, question.symbols + tuple(question.derived))
    return right_value


_JUDGED: dict[tuple, tuple[Judgement, Question, Key]] = {}
_JUDGED_MAX = 4096


def judge(question: Question, key: Key, value: object, right_value: object, seed: int,
          lettering: dict[str, str] | None = None, deadline: float | None = None,
          values: dict[str, float] | None = None, text: str = "") -> Judgement:
    """As `_judge`, once per process for the same question, key, answer, numbers and letters (a verdict
    depends on nothing else): a class's learners give the same answers to the same questions, and
    grade batch's workers judge them once. A verdict sympy left undecided is not kept."""
    right = (right_value.dtype.str, right_value.shape, right_value.tobytes()) if isinstance(right_value, np.ndarray) \
        else repr(right_value)  # every bit of an array (its repr rounds, and formats slowly)
    memo = (id(question), id(key), type(value).__name__, repr(value), right, seed, text,
            tuple((lettering or {}).items()), tuple(sorted((values or {}).items())))
    kept = _JUDGED.get(memo)
    if kept is not None:
        return dataclasses.replace(kept[0])
    verdict = _judge(question, key, value, right_value, seed, lettering, deadline, values, text)
    if not verdict.undecided:
        if len(_JUDGED) >= _JUDGED_MAX:
            _JUDGED.clear()
        _JUDGED[memo] = (dataclasses.replace(verdict), question, key)  # the objects kept: their ids stay theirs
    return verdict


def _judge(question: Question, key: Key, value: object, right_value: object, seed: int,
           lettering: dict[str, str] | None = None, deadline: float | None = None,
           values: dict[str, float] | None = None, text: str = "") -> Judgement:
    """The verdict on `value` (letters as shown through `lettering`, default the bank's own) against
    `right_value`; feedback of a wrong option names it by its shown letter, a wrong value or
    expression that matches a known mistake (grader.quiz.mistakes; `values`: the learner's numbers,
    which also fill in a per-learner symbolic key) gets that mistake's name and sentence. AnswerError
    when the answer cannot be read. A symbolic answer that sympy must decide is decided in a separate
    process within SIMPLIFY_SECONDS and before `deadline` (time.monotonic()), else `undecided`."""
    lettering = lettering or identity_lettering(question)
    got = read_answer(question, value, lettering, text)
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
        want = right_numbers(right_value, key, values)
        if got.shape != want.shape:
            raise AnswerError(f"expected {want.size} number(s), got {got.size}")
        close = bool(np.all(np.abs(got - want) <= key.atol + key.rtol * np.abs(want)))
        if close:
            return Judgement(1.0, key.explanation, True)
        outside = (f"not within the tolerance of the right value ({tolerance_text(key.rtol, key.atol)}"
                   f"{' in every entry' if want.ndim else ''})")
        mistake = numbers_mistake(question, key, got, want, values or {})
        if mistake is not None:
            return Judgement(0.0, f"{mistake.help}\n{outside}", mistake=mistake.name)
        return Judgement(0.0, outside)
    right = right_answer(question, key, right_value, values)
    with Simplifier(deadline) as simplifier:  # a process only if sympy must decide
        same = equivalent(got, right, question.symbols, question.domain, seed, simplifier, derived=question.derived)
        if same:
            return Judgement(1.0, key.explanation, True)
        if same is None:
            return Judgement(0.0, UNDECIDED, undecided=True, out_of_time=simplifier.out_of_time)
    mistake = expression_mistake(question, key, got, right, seed, values or {})
    if mistake is not None:
        return Judgement(0.0, mistake.help, mistake=mistake.name)
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
