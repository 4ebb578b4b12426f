"""Name the mistake behind a wrong quiz answer: the answer compared with the known wrong versions of
the right one, as grader.judging.diagnose does for code.

Numbers, vectors and matrices (`numbers_mistake`): first the key's own wrong answers, in their order
(`wrong:` entries: stored numbers, or expressions in the question's parameters evaluated for this
learner, or a transform or factor of the key), then degrees for an angle key (`angle: true`), then
the generic slips of any value (grader.judging.diagnose.generic: transposed, every sign, one row's, one
column's or one entry's sign, rows, columns or entries swapped), named with the question's own
entry names (`entries:` in the bank). Expressions (`expression_mistake`): the key's own wrong
answers (expressions in the question's symbols and, for a per-learner question, its parameters,
filled in with this learner's numbers), then minus the key ("every sign") and a constant multiple
of it ("constant factor"), compared by the quiz's own numeric equivalence and never by sympy.

A mistake is named only for an answer that is not right, only when the answer equals the mistake's
value within the key's tolerance, and only when that value is not itself right.
"""

from __future__ import annotations

import numpy as np

from grader.judging.compare import Entries, fmt
from grader.judging.diagnose import Mistake, diagnose
from grader.quiz.bank import Key, Question
from grader.quiz.symbolic import (
    AnswerError,
    Undefined,
    check_text,
    equivalent,
    evaluate,
    ratio,
    substitute,
)

DEGREES = Mistake("degrees", "The answer is in degrees: give the angle in radians (times pi/180).")
SYMBOLS = {"numeric": "your answer", "vector": "your vector", "matrix": "your matrix"}


def entries(question: Question) -> Entries:
    """How messages name the entries of the question's answer (its `entries:` in the bank)."""
    spec = question.entries
    return Entries(str(spec.get("symbol", SYMBOLS.get(question.kind, "your answer"))),
                   tuple(map(str, spec.get("rows", ()))), tuple(map(str, spec.get("cols", ()))),
                   bool(spec.get("derivative", False)))


def learner_names(key: Key, values: dict[str, float]) -> dict[str, float]:
    """The names a key's expressions may use for one learner: the question's parameters with their
    values, and the key's `derived` names evaluated from them."""
    names = dict(values)
    for name, text in key.derived.items():
        try:
            names[name] = evaluate(check_text(text, tuple(names)), names)
        except (AnswerError, Undefined):  # not defined for these numbers: expressions using it have no value
            continue
    return names


def numbers(value: object, names: dict[str, float]) -> np.ndarray:
    """A stored answer as floats: numbers, or expressions (strings) in `names`, nested in lists.
    AnswerError or Undefined when an expression cannot be evaluated with these names."""
    def one(item: object) -> object:
        if isinstance(item, np.ndarray):  # computed by a reference
            return item.astype(float)
        if isinstance(item, (list, tuple)):
            return [one(part) for part in item]
        if isinstance(item, str):
            return evaluate(check_text(item, tuple(names)), names)
        return float(item)

    return np.asarray(one(value), dtype=float)


def _transformed(want: np.ndarray, transform: str) -> np.ndarray | None:
    if transform == "transpose":
        return want.T if want.ndim == 2 and want.shape[0] == want.shape[1] and not np.allclose(want, want.T) else None
    with np.errstate(divide="ignore", invalid="ignore"):
        return {"negate": -want, "degrees": np.degrees(want), "reciprocal": 1.0 / want,
                "sqrt": np.sqrt(want), "square": want ** 2}[transform]


def wrong_value(wrong: dict, want: np.ndarray, names: dict[str, float]) -> np.ndarray | None:
    """The value of one of a key's wrong answers for this learner (None where it has none)."""
    if "transform" in wrong:
        return _transformed(want, wrong["transform"])
    if "factor" in wrong:
        return float(wrong["factor"]) * want
    try:
        return numbers(wrong["answer"], names)
    except (AnswerError, Undefined, ValueError):
        return None


def known_mistakes(key: Key, want: np.ndarray, values: dict[str, float]) -> list[Mistake]:
    """The key's own mistakes with their values for this learner, then degrees for an angle."""
    names = learner_names(key, values)
    out = [Mistake(wrong["name"], wrong["feedback"], wrong_value(wrong, want, names)) for wrong in key.wrong]
    if key.angle:
        out.append(Mistake(DEGREES.name, DEGREES.help, np.degrees(want)))
    return out


def numbers_mistake(question: Question, key: Key, got: np.ndarray, want: np.ndarray,
                    values: dict[str, float]) -> Mistake | None:
    """The first mistake (the key's own, degrees, then the generic slips) that `got` equals."""
    known = known_mistakes(key, want, values)
    names = entries(question)
    found = diagnose(got, want, known, names, key.rtol, key.atol)
    if found is None or any(found is mistake for mistake in known) or \
            "symbol" in question.entries and found.help.startswith(names.symbol):  # H[1,0] = ... stays as it is
        return found
    return Mistake(found.name, found.help[:1].upper() + found.help[1:], found.value)  # a generic one leads a message


def wrong_expression(question: Question, wrong: dict, values: dict[str, float]) -> str:
    """One of a symbolic key's wrong answers for one learner: the question's parameters in it replaced by
    the learner's numbers (`values`). AnswerError if it does not read."""
    return substitute(str(wrong["answer"]), values, question.symbols + tuple(question.derived))


def expression_mistake(question: Question, key: Key, got: str, right: str, seed: int,
                       values: dict[str, float] | None = None) -> Mistake | None:
    """The first of the key's wrong expressions (with the learner's numbers `values` for the question's
    parameters) that `got` equals, else minus or a constant multiple of the right expression; decided by
    the numbers alone (never sympy)."""
    same = {"symbols": question.symbols, "domain": question.domain, "seed": seed, "derived": question.derived}
    for wrong in key.wrong:
        try:  # the learner's numbers stand in for the parameters where it is evaluated (as wrong_expression
            candidate = str(wrong["answer"])  # writes them in, but parsed once for every learner)
            if equivalent(got, candidate, decide=False, bound=values, **same) and \
                    not equivalent(candidate, right, decide=False, bound=values, **same):
                return Mistake(wrong["name"], wrong["feedback"])
        except AnswerError:
            continue  # a wrong answer the bank's own test would have refused
    factor = ratio(got, right, **same)
    if factor is None or abs(factor - 1) < 1e-6:
        return None
    if abs(factor + 1) < 1e-6:
        return Mistake("every sign", "Your expression has the wrong sign: it is minus the right one.")
    return Mistake("constant factor", f"Your expression is {fmt(factor)} times the right one: look for a constant "
                                      "factor that is missing or one too many.")
