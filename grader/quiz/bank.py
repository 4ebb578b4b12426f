"""Question banks (quizzes/chNN.yaml) and their keys (quizzes/keys/chNN.yaml), kept apart.

A question says what is asked; its key, in a separate file, says what is right, how close is close
enough, and what each wrong answer means. Parametrised questions draw their numbers per learner
(seeded by a SHA-256 of learner id, chapter and question: the same on every run and machine), drawn
again where a question's `avoid` says the numbers make a known slip indistinguishable from the key
(`grade selftest` finds such numbers);
the key of a numeric one is computed by the reference implementation
(grader.judging.expected.reference_function, trusted code imported in the grading process), never stored;
that of a symbolic one (a derivation per learner: the map itself holds the numbers) is an
expression in the question's symbols and parameters, each learner's numbers put in where it is
judged. Neither ships with a handout. The options of a choice or multi question are shown to each
learner in their own order (another SHA-256 seed), so the letter of the right option differs
between learners; keys and feedback name the options by their canonical letters.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import random
import string
from dataclasses import dataclass, field
from pathlib import Path

import yaml

SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml when present: 10x faster


def _quiz_dir() -> Path:
    """The question banks: package data of an installed grader (grader/quizzes), else the checkout's quizzes/."""
    here = Path(__file__).resolve().parents[1]
    installed = here / "quizzes"
    return installed if installed.is_dir() else here.parent / "quizzes"


QUIZ_DIR = _quiz_dir()  # the default of every quiz_dir argument, read at call time
KINDS = ("choice", "multi", "numeric", "vector", "matrix", "symbolic")
SMALLEST = 0.5  # a per-learner number is at least this in size
MAX_DRAWS = 1000  # draws of a learner's numbers before a range (or its `avoid`) is called one that leaves none


class BankError(ValueError):
    """A question bank or key file that is not valid; the message names the file and line."""


class KeyUnavailable(RuntimeError):
    """A key that cannot be computed here (the reference implementation is not installed)."""


OPTIONS_SALT = "options"  # variant_seed salt of the option order (the numbers use no salt)


def variant_seed(learner: str, chapter: str, question: str, salt: str = "") -> int:
    """The seed of one learner's variant of one question (its numbers; with `salt` "options", its
    option order): stable across runs, machines and Python versions (hashlib, not hash())."""
    text = f"{learner}\x00{chapter}\x00{question}" + (f"\x00{salt}" if salt else "")
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "big")


@dataclass
class Question:
    id: str
    kind: str
    prompt: str
    points: float = 1.0
    options: dict[str, str] = field(default_factory=dict)
    symbols: tuple[str, ...] = ()
    params: dict[str, list] = field(default_factory=dict)
    shape: tuple[int, ...] = ()
    answer_format: str = ""
    domain: dict[str, tuple[float, float]] = field(default_factory=dict)  # symbolic: symbol -> range
    derived: dict[str, str] = field(default_factory=dict)  # symbolic: a symbol answers may use -> its definition
    entries: dict = field(default_factory=dict)  # vector/matrix: symbol, rows, cols, derivative (grader.judging.compare.Entries)
    # numbers drawn again: expression in the params -> the size it must exceed (0: it must not be 0), e.g.
    # {"r - 1": 0} where r = 1 makes 1/r^2 equal its reciprocal, so that a learner's slip could not be told apart
    avoid: dict[str, float] = field(default_factory=dict)

    def values_for(self, learner: str, chapter: str) -> dict[str, float]:
        """This learner's numbers for a parametrised question (empty for a fixed one): each
        parameter uniform in its range, one decimal, at least 0.5 in size; all of them drawn again
        while one of the `avoid` expressions is within its size of 0 (the same draws as without
        `avoid` for every learner it does not concern). BankError for a range (or `avoid`) that
        leaves no numbers."""
        draw = random.Random(variant_seed(learner, chapter, self.id))
        for _ in range(MAX_DRAWS):
            values = {}
            for name, (low, high) in self.params.items():
                for _ in range(MAX_DRAWS):
                    value = round(draw.uniform(low, high), 1)
                    if abs(value) >= SMALLEST:
                        values[name] = value
                        break
                else:
                    raise BankError(f"question {self.id}: its parameter {name} in [{low:g}, {high:g}] has no value "
                                    f"of size {SMALLEST:g} or more with one decimal")
            if not self.avoided(values):
                return values
        raise BankError(f"question {self.id}: its `avoid` leaves (almost) no numbers in its parameters' ranges")

    def avoided(self, values: dict[str, float]) -> str:
        """The `avoid` expression these numbers make (almost) 0, or "" (an expression without a value here,
        e.g. a division by 0, is avoided too)."""
        from grader.quiz.symbolic import AnswerError, Undefined, evaluate

        for text, size in self.avoid.items():
            try:
                if abs(evaluate(_avoid_tree(text, tuple(self.params)), values)) <= max(float(size), 1e-9):
                    return text
            except (Undefined, AnswerError):
                return text
        return ""

    def text_for(self, values: dict[str, float]) -> str:
        """The prompt with this learner's numbers filled in."""
        return self.prompt.format(**{k: f"{v:g}" for k, v in values.items()}) if values else self.prompt

    def lettering(self, learner: str, chapter: str) -> dict[str, str]:
        """Shown letter -> canonical letter, in the order this learner sees the options: a, b, c ...
        for a permutation of the bank's options seeded by variant_seed(..., OPTIONS_SALT)."""
        order = list(self.options)
        random.Random(variant_seed(learner, chapter, self.id, OPTIONS_SALT)).shuffle(order)
        return dict(zip(string.ascii_lowercase, order))


TRANSFORMS = ("transpose", "negate", "degrees", "reciprocal", "sqrt", "square")
WRONG_FORMS = ("answer", "transform", "factor")


@dataclass
class Key:
    answer: object = None
    rtol: float = 1e-3
    atol: float = 1e-6
    feedback: dict[str, str] = field(default_factory=dict)  # option -> why it is wrong
    # known wrong answers: {name, feedback, and one of: answer (numbers, or expressions in the question's
    # params and `derived`; symbolic: an expression), transform (TRANSFORMS), factor (times the key)}
    wrong: list[dict] = field(default_factory=list)
    # the symbolic `answer` and `wrong` expressions of a per-learner question may use its params: each learner's
    # numbers are put in where it is judged (judge.right_answer, mistakes.wrong_expression)
    compute: dict | None = None  # {function: a reference of the chapter, args: [param names], item: index}
    explanation: str = ""
    angle: bool = False  # the answer is an angle in radians: one in degrees is named
    derived: dict[str, str] = field(default_factory=dict)  # names the wrong answers' expressions may use

    def value_for(self, chapter: str, values: dict[str, float]) -> object:
        """The right answer: stored, or computed for `values` by the chapter's reference function
        (grader.judging.expected.reference_function); KeyUnavailable where the references are not installed."""
        if self.compute is None:
            return self.answer
        from grader.judging.expected import ReferenceUnavailable, reference_function

        try:
            reference = reference_function(chapter, self.compute["function"])
        except ReferenceUnavailable as exc:
            raise KeyUnavailable(str(exc)) from None

        def resolve(arg: object) -> object:
            if isinstance(arg, list):
                return [resolve(a) for a in arg]
            if isinstance(arg, str) and arg.startswith("$"):  # a catalogue callable, e.g. $sqrt
                from grader.catalogue import CALLABLES

                return CALLABLES[arg[1:]]
            return values[arg] if isinstance(arg, str) else arg

        result = reference(*[resolve(a) for a in self.compute.get("args", [])])
        if "item" in self.compute:
            result = result[tuple(self.compute["item"])] if isinstance(self.compute["item"], list) \
                else result[self.compute["item"]]
        return result


@functools.lru_cache(maxsize=256)
def _avoid_tree(text: str, names: tuple[str, ...]):
    from grader.quiz.symbolic import check_text

    return check_text(text, names)


def _load(path: Path) -> object:
    try:
        return yaml.load(path.read_text(encoding="utf-8"), Loader=SAFE_LOADER)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark
        raise BankError(f"{path}: line {mark.line + 1 if mark else '?'}: {exc.problem}") from None


def questions(chapter: str, quiz_dir: Path | None = None) -> list[Question]:
    """The chapter's questions in `quiz_dir` (default QUIZ_DIR), read once per process; do not
    modify the list."""
    return _questions(chapter, quiz_dir or QUIZ_DIR)


@functools.lru_cache(maxsize=32)
def _questions(chapter: str, quiz_dir: Path) -> list[Question]:
    path = quiz_dir / f"{chapter}.yaml"
    data = _load(path)
    out = []
    for raw in (data or {}).get("questions", []):
        if raw.get("kind") not in KINDS:
            raise BankError(f"{path}: question {raw.get('id')!r} has kind {raw.get('kind')!r}; one of {KINDS}")
        out.append(Question(
            id=str(raw["id"]), kind=raw["kind"], prompt=str(raw["prompt"]).strip(),
            points=float(raw.get("points", 1)),
            options={str(k): str(v) for k, v in (raw.get("options") or {}).items()},
            symbols=tuple(raw.get("symbols", ())), params=dict(raw.get("params") or {}),
            shape=tuple(raw.get("shape", ())), answer_format=str(raw.get("format", "")),
            domain={str(k): (float(v[0]), float(v[1])) for k, v in (raw.get("domain") or {}).items()},
            derived={str(k): str(v) for k, v in (raw.get("derived") or {}).items()},
            entries=dict(raw.get("entries") or {}), avoid=_avoid(path, raw),
        ))
    return out


def _avoid(path: Path, raw: dict) -> dict[str, float]:
    """A question's `avoid` ({expression in its params: size}), each expression checked; BankError naming the
    file and question for one that does not read."""
    from grader.quiz.symbolic import AnswerError

    avoid = raw.get("avoid") or {}
    names = tuple(str(n) for n in (raw.get("params") or {}))
    if not isinstance(avoid, dict):
        raise BankError(f"{path}: question {raw.get('id')!r}: avoid is a mapping {{expression in the params: size}}")
    out = {}
    for text, size in avoid.items():
        try:
            _avoid_tree(str(text), names)
            out[str(text)] = float(size)
        except (AnswerError, TypeError, ValueError) as exc:
            raise BankError(f"{path}: question {raw.get('id')!r}: avoid {text!r}: {exc}") from None
    return out


KEY_FOLDERS = ("keys", "practice")  # the instructor's keys; the practice keys an immediate-feedback handout ships


@functools.lru_cache(maxsize=32)
def _raw_keys(chapter: str, quiz_dir: Path) -> dict | None:
    path = next((p for p in (quiz_dir / f / f"{chapter}.yaml" for f in KEY_FOLDERS) if p.exists()), None)
    if path is None:
        return None
    data = _load(path) or {}
    if not isinstance(data, dict):
        raise BankError(f"{path}: expected `question_id:` entries")
    return data


def keys(chapter: str, quiz_dir: Path | None = None) -> dict[str, Key] | None:
    """The chapter's keys in `quiz_dir` (default QUIZ_DIR), or None when its keys file is not
    shipped (read once per process; do not modify the dict)."""
    return _keys(chapter, quiz_dir or QUIZ_DIR)


@functools.lru_cache(maxsize=32)
def _keys(chapter: str, quiz_dir: Path) -> dict[str, Key] | None:
    data = _raw_keys(chapter, quiz_dir)
    if data is None:
        return None
    return {str(qid): Key(
        answer=raw.get("answer"), rtol=float(raw.get("rtol", 1e-3)), atol=float(raw.get("atol", 1e-6)),
        feedback={str(k): str(v) for k, v in (raw.get("feedback") or {}).items()},
        wrong=_wrong_entries(chapter, str(qid), raw.get("wrong")), compute=raw.get("compute"),
        explanation=str(raw.get("explanation", "")).strip(), angle=bool(raw.get("angle", False)),
        derived={str(k): str(v) for k, v in (raw.get("derived") or {}).items()},
    ) for qid, raw in data.items()}


def _wrong_entries(chapter: str, qid: str, raw: object) -> list[dict]:
    """A key's known wrong answers, each checked: a dict with a `name` (the stable name of the
    mistake, CheckResult.mistake), its `feedback`, and exactly one of WRONG_FORMS."""
    entries = list(raw or [])
    for number, entry in enumerate(entries, 1):
        where = f"keys of {chapter}, question {qid}, wrong answer {number}"
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str) or not entry["name"].strip():
            raise BankError(f"{where}: needs a `name` (the mistake's stable name)")
        if not isinstance(entry.get("feedback"), str) or not entry["feedback"].strip():
            raise BankError(f"{where} ({entry['name']}): needs its `feedback`")
        forms = [form for form in WRONG_FORMS if form in entry]
        if len(forms) != 1:
            raise BankError(f"{where} ({entry['name']}): needs exactly one of {', '.join(WRONG_FORMS)}")
        if forms == ["transform"] and entry["transform"] not in TRANSFORMS:
            raise BankError(f"{where} ({entry['name']}): unknown transform {entry['transform']!r}; "
                            f"one of {', '.join(TRANSFORMS)}")
    return entries


def public_keys(chapter: str, quiz_dir: Path | None = None) -> dict:
    """The keys of `chapter` that may ship in an immediate-feedback handout: the keys of the questions
    that are the same for everyone, that is every key that needs no reference computation (no
    `compute:`) of a question without per-learner numbers (no `params`: a per-learner symbolic key
    written in the parameters is the general answer to everyone's variant), as plain data shaped like
    quizzes/keys/chNN.yaml (yaml.safe_dump it there and keys() reads it back). Empty when the keys
    are not installed."""
    folder = quiz_dir or QUIZ_DIR
    data = _raw_keys(chapter, folder) or {}
    if not data:
        return {}
    per_learner = {question.id for question in questions(chapter, folder) if question.params}
    return {qid: copy.deepcopy(raw) for qid, raw in data.items() if "compute" not in raw and qid not in per_learner}
