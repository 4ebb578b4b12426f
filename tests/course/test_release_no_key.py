"""No stub, answer template, check description or handout text holds a quiz key.

Every expression in those texts is read (tokens of numbers, the quiz's symbols and functions, operators
and brackets, between words of prose; split at `=`, `->` and comparisons, at the commas of a list, and
into the entries of a vector or matrix) and parsed with sympy. None may be equivalent to a key of
quizzes/keys/*.yaml:
- a symbolic key (`answer:` of a symbolic question), as a function of the question's symbols (a derived
  symbol such as r stands for its definition): equal at random points, confirmed by sympy's simplify;
- a fixed numeric, vector or matrix key, for a value of that shape stated as a result (after `->`, or
  after `=` but for `n = 2`, which names a number): within the key's own tolerance (a single number only
  in its own chapter's texts);
- a per-learner key computed by a reference derivative (`compute:`), for an expression of the question's
  parameters (not a bare name): equal to the reference at random parameters.
The handout is built by `grade release`; its recorded check data (grader/data/expected) holds the values
its checks compare against by design, so it is not read here."""

from __future__ import annotations

import ast
import functools
import math
import re
import warnings
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import yaml

from grader import checks as check_registry
from grader.chapters import CHAPTERS
from grader.judging.expected import reference_function
from tests.support import (
    REPO,
    run_grade,
)

sympy = pytest.importorskip("sympy")
from sympy.parsing.sympy_parser import (  # noqa: E402
    convert_xor,
    implicit_application,
    implicit_multiplication,
    parse_expr,
    standard_transformations,
)

TRANSFORMATIONS = standard_transformations + (implicit_multiplication, implicit_application, convert_xor)
FUNCTIONS = {"sqrt": sympy.sqrt, "sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan, "atan": sympy.atan,
             "atan2": sympy.atan2, "exp": sympy.exp, "log": sympy.log, "abs": sympy.Abs, "Abs": sympy.Abs}
ALIASES = {"th": "theta", "θ": "theta", "π": "pi", "−": "-", "²": "^2", "·": "*", "×": "*"}
# the derivatives the lesson asks for, whose per-learner keys an expression of the parameters would give away
DERIVED = {"area_scale", "volume_scale", "measurement_covariance", "linearized_measurement_cov",
           "control_noise_covariance"}
POINTS = 10
# (file name, expression, key) that must stand where they stand, and why
POLAR_MAP = "the polar map x = r cos(theta), which the contract makes polar_to_cartesian's stub and checks state, " \
            "equals d y / d theta"
ALLOWED = {("ch03_jacobian.py", "r cos theta", "dy_dtheta"): POLAR_MAP,
           ("ch03.py", "r cos theta", "dy_dtheta"): POLAR_MAP}
# found in the handout in files of the quiz (grader/quiz/, not this test's to change); reported to its owner
READER_EXAMPLES = "the quiz reader's module docstring shows how answers may be written with these very keys"
KNOWN = {("symbolic.py", "6 x - 9", "tangent_of_square"): READER_EXAMPLES,
         ("symbolic.py", "r ^ - 2", "bearing_variance"): READER_EXAMPLES,
         ("symbolic.py", "r cos ( theta )", "dy_dtheta"): READER_EXAMPLES}


@dataclass(frozen=True)
class Key:
    chapter: str
    question: str
    kind: str
    names: tuple[str, ...]  # the free names an equivalent expression may use (symbols or parameters)
    derived: tuple[tuple[str, str], ...]
    answer: object = None  # sympy expression, or a nested list of numbers
    compute: dict | None = None
    domain: tuple[tuple[str, float, float], ...] = ()
    rtol: float = 5e-3
    atol: float = 0.0


def _sympify(text: object, names: set[str], derived: dict[str, str]):
    local = {n: sympy.Symbol(n) for n in names} | FUNCTIONS | {"pi": sympy.pi}
    expr = parse_expr(str(text).replace("^", "**"), local_dict=local, transformations=TRANSFORMATIONS)
    for _ in range(3):  # derived symbols may use each other
        expr = expr.subs({sympy.Symbol(n): _sympify(d, names - {n}, {}) for n, d in derived.items()})
    return expr


@functools.lru_cache(maxsize=1)
def keys() -> tuple[Key, ...]:
    out = []
    for info in CHAPTERS:
        bank_path, key_path = REPO / "quizzes" / f"{info.id}.yaml", REPO / "quizzes" / "keys" / f"{info.id}.yaml"
        if not bank_path.is_file() or not key_path.is_file():
            continue
        bank = yaml.safe_load(bank_path.read_text(encoding="utf-8"))
        stored = yaml.safe_load(key_path.read_text(encoding="utf-8")) or {}
        for question in bank["questions"]:
            key, kind = stored.get(question["id"]) or {}, question["kind"]
            if kind in ("choice", "multi") or not key:
                continue
            params = question.get("params") or {}
            derived = {**(question.get("derived") or {}), **(key.get("derived") or {})}
            names = set(question.get("symbols") or ()) | set(params) | set(derived)
            common = dict(chapter=info.id, question=question["id"], kind=kind, names=tuple(sorted(names)),
                          derived=tuple(sorted(derived.items())), rtol=float(key.get("rtol", 5e-3)),
                          atol=float(key.get("atol", 0.0)),
                          domain=tuple((n, float(lo), float(hi)) for n, (lo, hi) in params.items()))
            if "answer" in key and kind == "symbolic":
                out.append(Key(**common, answer=_sympify(key["answer"], names, derived)))
            elif "answer" in key and not params:
                out.append(Key(**common, answer=_numbers(key["answer"], names, derived)))
            elif "compute" in key and key["compute"]["function"] in _derivatives() and params:
                out.append(Key(**common, compute=key["compute"]))
    return tuple(out)


@functools.lru_cache(maxsize=1)
def _derivatives() -> frozenset[str]:
    exact = {c.function for info in CHAPTERS for c in check_registry.load(info.id).checks if c.exact_derivative}
    return frozenset(exact | DERIVED)


def _numbers(answer: object, names: set[str], derived: dict[str, str]) -> object:
    if isinstance(answer, list):
        return [_numbers(a, names, derived) for a in answer]
    return float(_sympify(answer, names, derived))


# ------------------------------------------------------------------------------ reading the texts

TOKEN = re.compile(r"\d+\.\d*(?:e[-+]?\d+)?|\d*\.?\d+(?:e[-+]?\d+)?|[A-Za-z_][A-Za-z_0-9]*|\*\*|->|<=|>=|[-+*/^(),\[\]=<>]|\S")
SEPARATORS = {"=", "->", "<", ">", "<=", ">="}


@functools.lru_cache(maxsize=1)
def _allowed_names() -> frozenset[str]:
    return frozenset({n for k in keys() for n in k.names} | set(FUNCTIONS) | {"pi"} | set(ALIASES))


def _runs(text: str) -> list[list[str]]:
    """Maximal runs of math tokens (numbers, allowed names, operators, brackets); prose breaks a run."""
    for old, new in ALIASES.items():
        if not old.isalpha():
            text = text.replace(old, new)
    runs, current = [], []
    for token in TOKEN.findall(text):
        token = ALIASES.get(token, token)
        mathy = (token[0].isdigit() or token[0] == "." and len(token) > 1 or token in _allowed_names()
                 or token in SEPARATORS or token in set("+-*/^(),[]") or token == "**")
        if mathy:
            current.append(token)
        else:
            if current:
                runs.append(current)
            current = []
    if current:
        runs.append(current)
    return runs


def _balanced(tokens: list[str]) -> list[str]:
    """The tokens without stray commas or operators at either end, and without an unmatched bracket at the
    start; [] when the brackets still do not match."""
    while tokens and tokens[0] in {",", ")", "]", "*", "/", "^", "**"}:
        tokens = tokens[1:]
    while tokens and tokens[-1] in {",", "(", "[", "+", "-", "*", "/", "^", "**"}:
        tokens = tokens[:-1]
    depth = 0
    for i, token in enumerate(tokens):
        depth += (token in ("(", "[")) - (token in (")", "]"))
        if depth < 0:
            return _balanced(tokens[i + 1:])
    if depth > 0 and tokens and tokens[0] in ("(", "["):
        return _balanced(tokens[1:])
    return tokens if depth == 0 else []


def _top_level_split(tokens: list[str], separator: str) -> list[list[str]]:
    parts, depth, current = [], 0, []
    for token in tokens:
        depth += token in ("(", "[")
        depth -= token in (")", "]")
        if token == separator and depth == 0:
            parts.append(current)
            current = []
        else:
            current.append(token)
    return parts + [current]


BINARY = {"^", "**", "*", "/"}


def _whole(run: list[str]) -> list[str]:
    """The run without a fragment of a longer expression at either end: a run that starts (or ends) with a
    binary operator continues a name of prose (sigma^2 / 2r: the run is ^2 / 2r), so its first (last) part, up
    to a comma or separator at the top level, is no expression of its own."""
    def cut(tokens: list[str]) -> list[str]:
        if not tokens or tokens[0] not in BINARY:
            return tokens
        depth = 0
        for i, token in enumerate(tokens):
            depth += (token in ("(", "[")) - (token in (")", "]"))
            if depth <= 0 and (token == "," or token in SEPARATORS):
                return tokens[i + 1:]
        return []

    return cut(cut(run)[::-1])[::-1] if run else run


@dataclass(frozen=True)
class Candidate:
    text: str  # its tokens, separated by spaces
    result: bool  # stated as a result: after = or -> (or inside a list that is)


def candidates(text: str) -> set[Candidate]:
    found: set[Candidate] = set()

    def add(tokens: list[str], result: bool) -> None:
        tokens = _balanced(tokens)
        if not tokens:
            return
        found.add(Candidate(" ".join(tokens), result))
        bracketed = tokens[0] in ("(", "[") and tokens[-1] in (")", "]")
        inner = tokens[1:-1] if bracketed and _balanced(tokens[1:-1]) == tokens[1:-1] else None
        parts = _top_level_split(inner if inner is not None else tokens, ",")
        if len(parts) > 1 or inner is not None:
            for part in parts:
                add(part, result)

    for run in _runs(text):
        run = _whole(run)
        pieces, current = [], []
        for token in run:
            if token in SEPARATORS:
                pieces.append((current, token))
                current = []
            else:
                current.append(token)
        pieces.append((current, None))
        for i, (tokens, _) in enumerate(pieces):
            before, separator = pieces[i - 1] if i else ([], None)
            # n = 2 names a number (as does `count = 2`, whose name is prose here): it states no result
            defines = not before or len(before) == 1 and before[0][0].isalpha()
            add(tokens, result=separator == "->" or separator == "=" and not defines)
    return found


# ------------------------------------------------------------------------------ comparing

def _value(tokens: list[str]):
    """The tokens as a sympy expression, or a nested list of them for a bracketed list; None when they do not
    parse."""
    if len(tokens) > 2 and tokens[0] in ("(", "[") and tokens[-1] in (")", "]") and \
            _balanced(tokens[1:-1]) == tokens[1:-1]:
        parts = _top_level_split(tokens[1:-1], ",")
        if len(parts) > 1 or tokens[0] == "[":
            return [_value(part) for part in parts]
    names = set(_allowed_names()) - set(FUNCTIONS) - {"pi"}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SyntaxWarning)  # sympy compiles what it reads: [1](2) warns
            return _sympify(" ".join(tokens), names, {})
    except Exception:  # noqa: BLE001 - prose that happens to look like math
        return None


def _shape(value) -> tuple:
    if isinstance(value, list):
        inner = {_shape(v) for v in value}
        return (len(value), *inner.pop()) if len(inner) == 1 and None not in inner else None
    return () if value is not None else None


def _points(key: Key, rng: np.random.Generator) -> list[dict[str, float]]:
    domain = {n: (lo, hi) for n, lo, hi in key.domain}
    return [{n: float(rng.uniform(*domain.get(n, (0.5, 3.0))) * (1 if n in domain else rng.choice([-1, 1])))
             for n in key.names if n not in dict(key.derived)} for _ in range(POINTS)]


@functools.lru_cache(maxsize=None)
def _function(expr, names: tuple[str, ...], derived: tuple[tuple[str, str], ...]):
    """The expression, derived symbols expanded, as a plain function of `names` (math on floats)."""
    expr = expr.subs({sympy.Symbol(n): _sympify(d, set(names), {}) for n, d in derived})
    return sympy.lambdify([sympy.Symbol(n) for n in names], expr, modules="math")


def _evaluate(expr, point: dict[str, float], derived: dict[str, str]) -> float:
    names = tuple(sorted(point))
    return float(_function(sympy.sympify(expr), names, tuple(sorted(derived.items())))(*(point[n] for n in names)))


def _flat(value) -> list:
    return [v for item in value for v in _flat(item)] if isinstance(value, list) else [value]


def _key_values(key: Key, point: dict[str, float]) -> np.ndarray | None:
    if key.compute is None:
        return None
    def argument(a):
        return [argument(x) for x in a] if isinstance(a, list) else point.get(a, a) if isinstance(a, str) else a
    try:
        value = np.asarray(reference_function(key.chapter, key.compute["function"])(
            *[argument(a) for a in key.compute.get("args", [])]), dtype=float)
    except ValueError:
        return None
    for index in [key.compute["item"]] if "item" in key.compute else []:
        value = value[tuple(index)]
    return np.asarray(value, dtype=float)


@dataclass(frozen=True)
class Parsed:
    """A candidate read once: its value (expression or nested list), shape, entries and free names."""

    candidate: Candidate
    value: object
    shape: tuple
    entries: tuple
    free: frozenset[str]


def parse(candidate: Candidate) -> Parsed | None:
    value = _value(candidate.text.split(" "))
    shape = _shape(value)
    if shape is None:
        return None
    entries = tuple(_flat(value))
    free = frozenset(str(s) for e in entries for s in sympy.sympify(e).free_symbols)
    return Parsed(candidate, value, shape, entries, free)


def equivalent(parsed: Parsed, key: Key, rng: np.random.Generator) -> bool:
    candidate, value, shape, entries, free = (parsed.candidate, parsed.value, parsed.shape, list(parsed.entries),
                                              parsed.free)
    if not free <= set(key.names):
        return False
    derived = dict(key.derived)
    if key.kind == "symbolic":
        if shape != ():
            return False
        points = _points(key, rng)
        try:
            if not all(math.isclose(_evaluate(value, p, derived), _evaluate(key.answer, p, derived),
                                    rel_tol=1e-9, abs_tol=1e-12) for p in points):
                return False
        except (TypeError, ValueError, ZeroDivisionError, OverflowError):
            return False
        expand = {sympy.Symbol(n): _sympify(d, set(key.names) - {n}, {}) for n, d in derived.items()}
        return sympy.simplify(value.subs(expand) - key.answer) == 0
    if key.compute is None:
        want = np.asarray(key.answer, dtype=float)
        if free or not candidate.result or shape != want.shape:
            return False
        got = np.array([float(e) for e in entries]).reshape(want.shape)
        return bool(np.all(np.abs(got - want) <= key.atol + key.rtol * np.abs(want)))
    if not free or len(candidate.text.split(" ")) == 1:
        return False  # a bare name (at r = 0, det J = r) is no expression of the parameters
    for point in _points(key, rng):
        want = _key_values(key, point)
        if want is None or shape != want.shape:
            return False
        got = np.array([_evaluate(sympy.sympify(e), point, derived) for e in entries]).reshape(want.shape)
        if not np.allclose(got, want, rtol=1e-6, atol=1e-9):
            return False
    return True


def _compared(key: Key, source: str) -> bool:
    """A single fixed number is compared with the texts of its own chapter only: elsewhere a 2 or a 100 is
    just a number, in its chapter's stub (sample_covariance's example) it is the answer."""
    if key.compute is not None or key.kind == "symbolic" or np.ndim(key.answer) > 0:
        return True
    return key.chapter in re.findall(r"ch\d\d", source)


@dataclass(frozen=True)
class Leak:
    source: str
    text: str
    key: Key

    def __str__(self) -> str:
        return f"{self.source}: `{self.text}` is the key of {self.key.chapter} {self.key.question}"

    def among(self, explained: dict) -> bool:
        return (self.source.split("/")[-1], self.text, self.key.question) in explained


def leaks(texts: dict[str, str]) -> list[Leak]:
    """Every (source, expression, key) where an expression of the texts is equivalent to a key, but the
    coincidences ALLOWED explains."""
    rng = np.random.default_rng(17)
    found = []
    for source, text in texts.items():
        chapter_keys = [k for k in keys() if _compared(k, source)]
        for candidate in sorted(candidates(text), key=lambda c: c.text):
            parsed = _parsed(candidate)
            if parsed is None:
                continue
            found += [leak for leak in (Leak(source, candidate.text, k) for k in chapter_keys
                                        if equivalent(parsed, k, rng)) if not leak.among(ALLOWED)]
    return found


@functools.lru_cache(maxsize=None)
def _parsed(candidate: Candidate) -> Parsed | None:
    return parse(candidate)


# ------------------------------------------------------------------------------ the texts

def _string_literals(source: str) -> str:
    return "\n".join(node.value for node in ast.walk(ast.parse(source))
                     if isinstance(node, ast.Constant) and isinstance(node.value, str))


def stub_texts() -> dict[str, str]:
    return {f"exercises/{p.name}": p.read_text(encoding="utf-8") for p in sorted((REPO / "exercises").glob("*.py"))}


def template_texts() -> dict[str, str]:
    return {f"exercises/answers/{p.name}": p.read_text(encoding="utf-8")
            for p in sorted((REPO / "exercises" / "answers").glob("*.yaml"))}


def check_texts() -> dict[str, str]:
    """What the grader says of each check (grade list --checks, every report) and the mistakes it names."""
    return {f"grader/checks/{info.id}.py": _string_literals((REPO / "grader" / "checks" / f"{info.id}.py")
                                                            .read_text(encoding="utf-8"))
            for info in CHAPTERS}


def handout_texts(out: Path) -> dict[str, str]:
    """The texts of the handout in `out`: its files and the members of its wheel a learner reads (the string
    literals of Python files)."""
    texts = {}
    for path in sorted(out.rglob("*")):
        name = path.relative_to(out).as_posix()
        if path.suffix == ".whl":
            with zipfile.ZipFile(path) as wheel:
                for member in wheel.namelist():
                    if member.startswith("grader/data/expected/") or not member.endswith((".py", ".yaml", ".md")):
                        continue
                    text = wheel.read(member).decode("utf-8")
                    texts[f"{name}!{member}"] = _string_literals(text) if member.endswith(".py") else text
        elif path.is_file() and path.suffix in (".py", ".yaml", ".md", ".yml"):
            texts[name] = path.read_text(encoding="utf-8")
    return texts


@pytest.fixture(scope="module")
def handout(tmp_path_factory) -> dict[str, str]:
    """The texts of a handout `grade release` built."""
    out = tmp_path_factory.mktemp("release") / "handout"
    done = run_grade("release", out)
    assert done.returncode == 0, done.stderr[-3000:]
    texts = handout_texts(out)
    assert any(n.startswith("exercises/") for n in texts) and any("grader/quizzes/" in n for n in texts)
    return texts


# ------------------------------------------------------------------------------ the tests

def test_the_reader_finds_the_keys_the_old_stubs_held():
    """The stubs before this test held four symbolic keys and three fixed numeric ones, and more; the reader
    finds each (where the quiz still asks that question: its owner may change the banks)."""
    old = {"exercises/ch06_measurement.py": "H = [[dr/dx, dr/dy], [dbearing/dx, dbearing/dy]]\n"
                                            "  = [[x/r, y/r], [-y/r^2, x/r^2]].\n"
                                            "Formula: H (sigma^2 I) H^T = sigma^2 diag(1, 1/r^2).",
           "exercises/ch03_jacobian.py (old)": "Formula: J = [[cos theta, -r sin theta], [sin theta, r cos theta]].",
           "exercises/ch07_dynamics.py": "Formula: F = [[1, 0, -v sin(theta) dt], [0, 1, v cos(theta) dt], [0, 0, 1]].",
           "exercises/ch02_gradient.py": "Example: f = x^2 + xy, a = (1, 2), x = (1.1, 2.1) -> 3 + (4, 1) . (0.1, 0.1) = 3.50",
           "exercises/ch04_chain_rule.py": "Example: pipeline_jacobian(4, pi/3) -> [[2.866, -11.856], [3.464, -8.000]]"}
    found = "\n".join(map(str, leaks(old)))
    wanted = [("ch00", "drange_dx"), ("ch06", "dbearing_dx"), ("ch03", "dy_dtheta"), ("ch07", "dx_dtheta"),
              ("ch02", "tangent_plane"), ("ch04", "pipeline"), ("ch06", "bearing_variance"), ("ch06", "H_at_point"),
              ("ch03", "polar_jacobian")]
    present = {(k.chapter, k.question) for k in keys()}
    assert len(present & set(wanted)) >= 5
    for chapter, question in wanted:
        if (chapter, question) in present:
            assert f"key of {chapter} {question}" in found, (chapter, question, found)
    assert leaks({"exercises/ch08_lab.py": "Returns: an array of shape (2, 2) for n = 2 samples. Raises: ValueError "
                                           "at r = 0. Example: f(1, 2) -> 4.5"}) == []
    assert leaks({"exercises/ch08_lab.py": "sample_covariance([[0, 0], [2, 2]]) -> [[2, 2], [2, 2]]"}) != []


@pytest.mark.slow
def test_no_stub_holds_a_key():
    assert [str(leak) for leak in leaks(stub_texts())] == []


@pytest.mark.slow
def test_no_check_description_or_named_mistake_holds_a_key():
    assert [str(leak) for leak in leaks(check_texts())] == []


@pytest.mark.slow
def test_no_answer_template_holds_a_key():
    assert [str(leak) for leak in leaks(template_texts())] == []


@pytest.mark.slow
def test_no_text_of_the_handout_holds_a_key(handout):
    assert [str(leak) for leak in leaks(handout) if not leak.among(KNOWN)] == []
