"""Every numeric comparison and its message, in one place.

Order of the sanity checks (after PrairieLearn's code_feedback and numpy.testing): did the call
give a value at all -> is it the right type (plain ndarray or real number) -> shape -> finite ->
values within `atol + rtol * |expected|`, naming the worst entries.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from grader.boundary.wire import RAISED, Returned
from grader.diagnose import SMALL, Mistake, diagnose, shape_mistake, within
from grader.numbers import fmt, fmt_array  # noqa: F401  (the checks' messages import them from here)

SHOWN_ENTRIES = 3


@dataclass
class Verdict:
    """A check's outcome before points are attached."""

    passed: bool
    message: str = ""
    expected: object = None
    got: object = None
    details: dict = field(default_factory=dict)
    mistake: Mistake | None = None  # the known mistake the wrong value matches (grader.diagnose)


@dataclass(frozen=True)
class Entries:
    """How to name the entries of a result: `H[1,0] = d bearing/d x` or `z[1] (bearing)`."""

    symbol: str
    rows: tuple[str, ...] = ()
    cols: tuple[str, ...] = ()
    derivative: bool = False

    def name(self, index: tuple[int, ...]) -> str:
        if len(index) == 0:
            return self.symbol
        text = f"{self.symbol}[{','.join(str(i) for i in index)}]"
        if len(index) == 2 and self.derivative and index[0] < len(self.rows) and index[1] < len(self.cols):
            return f"{text} = d {self.rows[index[0]]}/d {self.cols[index[1]]}"
        if len(index) == 2 and self.rows and self.cols and index[0] < len(self.rows) and index[1] < len(self.cols):
            return f"{text} ({self.rows[index[0]]}, {self.cols[index[1]]})"
        if len(index) == 1 and index[0] < len(self.rows):
            return f"{text} ({self.rows[index[0]]})"
        return text


@dataclass(frozen=True)
class Comparison:
    """One comparison of values as a check made it, for whoever watches (grade selftest, grader.selftest): the right
    value, the tolerance as the check gave it and whether it is exact, the check's own mistakes, the names of the
    entries where the generic slips apply (None where the value is compared with something other than the expected
    value), and the learner's Returned whose value was compared (None where not known)."""

    expected: np.ndarray
    rtol: float
    atol: float
    exact: bool
    mistakes: tuple
    entries: Entries | None
    source: object = None


_OBSERVER: contextvars.ContextVar[Callable[[Comparison], None] | None] = contextvars.ContextVar("observer",
                                                                                                 default=None)


@contextlib.contextmanager
def observing(callback: Callable[[Comparison], None]) -> Iterator[None]:
    """Within this block every comparison of values (compare_arrays) is given to `callback` first."""
    token = _OBSERVER.set(callback)
    try:
        yield
    finally:
        _OBSERVER.reset(token)


class Label:
    """A call's label for messages (`H_jacobian(3, 4)`), written the first time a message uses it: formatting
    the arguments of every call costs more than comparing the values, and most comparisons pass."""

    __slots__ = ("_make", "_text")

    def __init__(self, make: Callable[[], str]) -> None:
        self._make, self._text = make, None

    def __str__(self) -> str:
        if self._text is None:
            self._text = self._make()
        return self._text

    def __format__(self, spec: str) -> str:
        return format(str(self), spec)


SINGLE_PRECISION = 2e-6  # about 16 units in the last place of a float32: a few operations' round-off


def tolerance_text(rtol: float, atol: float) -> str:
    return f"tolerance |got - expected| <= {atol:g} + {rtol:g}*|expected|"


def value_problem(returned: Returned, expected_shape: tuple[int, ...], label: str | Label,
                  symbol: str = "result") -> str | None:
    """Why `returned` cannot be compared to a result of `expected_shape`, or None if it can."""
    if not returned.ok:
        return returned.problem()
    enc = returned.encoded
    want = "a real number" if expected_shape == () else f"a numpy array of shape {expected_shape}"
    t = enc["t"]
    if t in ("tuple", "list") and expected_shape != ():
        return f"{label} returned a {t}; the contract asks for a numpy array: wrap it in np.array(...)."
    if t == "ndarray" and expected_shape == () and tuple(enc["shape"]) != ():
        return f"{label} returned an array of shape {tuple(enc['shape'])}; expected {want} (use float(...))."
    if t == "scalar" and expected_shape != ():
        return f"{label} returned a single number ({enc['type']}); expected {want}."
    if t not in ("ndarray", "scalar"):
        shown = f" {enc['text']!r}" if t == "str" else ""
        return f"{label} returned {returned.type_name}{shown}; expected {want}."
    got = returned.as_array()
    if got is None:
        return f"{label} returned a malformed array."
    if got.shape != expected_shape:
        mistake = shape_mistake(got.shape, expected_shape, symbol)
        return f"{label} returned shape {got.shape}; expected shape {expected_shape}." + \
            (f" {mistake.help[0].upper()}{mistake.help[1:]}" if mistake else "")
    return None


def expect(returned: Returned, expected: object, *, label: str | Label, rtol: float = 1e-6,
           atol: float = 1e-9, entries: Entries | None = None, mistakes: tuple | list = (),
           exact: bool = False) -> Verdict:
    """Compare a learner's returned value with the expected number or array (see compare_arrays); a
    wrong value is named by the first of `mistakes` (then of the generic slips) it matches."""
    expected = np.asarray(expected, dtype=np.float64)
    symbol = (entries or Entries("result")).symbol
    problem = value_problem(returned, expected.shape, label, symbol)
    if problem is not None:
        got = returned.as_array() if returned.ok else None
        mistake = shape_mistake(got.shape, expected.shape, symbol) if got is not None else None
        return Verdict(False, problem, expected=expected,
                       details={"traceback": returned.traceback} if returned.traceback else {}, mistake=mistake)
    return compare_arrays(returned.as_array(), expected, label=label, rtol=rtol, atol=atol, entries=entries,
                          mistakes=mistakes, exact=exact)


def _all_within(got: list[float], expected: list[float], rtol: float, atol: float, exact: bool) -> bool:
    """Whether every entry is finite and within the tolerance compare_arrays uses (on plain floats: the
    common case of a right answer, decided without a dozen numpy calls). False sends the comparison
    through numpy, which also says what is wrong."""
    if not all(map(math.isfinite, got)) or not all(map(math.isfinite, expected)):
        return False
    if not exact:
        scale = max(map(abs, expected), default=0.0)
        rtol, atol = max(rtol, SINGLE_PRECISION), max(atol, SINGLE_PRECISION * scale)
    return within(got, expected, rtol, atol)


def compare_arrays(got: np.ndarray, expected: np.ndarray, *, label: str | Label, rtol: float = 1e-6,
                   atol: float = 1e-9, entries: Entries | None = None,
                   expected_name: str = "expected", mistakes: tuple | list = (), exact: bool = False,
                   digits: int = 6) -> Verdict:
    """Values of two float arrays of the same shape, with the worst entries named (to `digits` significant
    digits), and the mistake the wrong value matches (grader.diagnose) said first. Any real dtype is a right
    answer (the contract): unless `exact` (a check telling apart values closer than that, e.g.
    finite-difference conventions), the tolerance is at least single-precision round-off relative to the
    result's scale, so that float32 (jax's and torch's default), there or anywhere upstream, is right."""
    got = np.asarray(got, dtype=np.float64)
    expected = np.asarray(expected, dtype=np.float64)
    if got.shape != expected.shape:
        return Verdict(False, f"{label}: shape {got.shape}, expected {expected.shape}.", expected, got)
    observer = _OBSERVER.get()
    if observer is not None:  # grade selftest: what this comparison could tell apart
        observer(Comparison(expected, rtol, atol, exact, tuple(mistakes),
                            (entries or Entries("result")) if expected_name == "expected" else None))
    if got.size <= SMALL and _all_within(got.ravel().tolist(), expected.ravel().tolist(), rtol, atol, exact):
        return Verdict(True, "", expected, got)
    if not exact:
        scale = float(np.max(np.abs(expected[np.isfinite(expected)]), initial=0.0))
        rtol, atol = max(rtol, SINGLE_PRECISION), max(atol, SINGLE_PRECISION * scale)
    entries = entries or Entries("result")
    bad_got = ~np.isfinite(got)
    if bad_got.any() and not np.array_equal(bad_got, ~np.isfinite(expected)):
        where = [entries.name(tuple(int(i) for i in idx)) for idx in np.argwhere(bad_got)[:SHOWN_ENTRIES]]
        if got.ndim == 0:
            where = [entries.symbol]
        return Verdict(False, f"{label} is not finite: {', '.join(where)} = {fmt(got[tuple(np.argwhere(bad_got)[0])])}.",
                       expected, got, {"wrong": np.argwhere(bad_got).tolist()})
    diff = np.asarray(np.abs(got - expected))  # an array even for scalars (numpy returns a float64 there)
    diff[np.isnan(diff) & np.isnan(got) & np.isnan(expected)] = 0.0
    limit = atol + rtol * np.abs(expected)
    wrong = ~(diff <= limit)
    if not wrong.any():
        return Verdict(True, "", expected, got)
    order = np.argsort(-np.where(wrong, diff, -1.0), axis=None, kind="stable")
    worst = [tuple(int(i) for i in np.unravel_index(k, got.shape)) for k in order[: min(SHOWN_ENTRIES, int(wrong.sum()))]]
    lines = []
    tiny = atol / 10  # below a tenth of the tolerance a number reads as 0
    if got.ndim == 0:
        lines.append(f"{label}: got {fmt(got, tiny, digits)}, {expected_name} {fmt(expected, tiny, digits)}")
    else:
        lines.append(f"{label}: {int(wrong.sum())} of {got.size} entries differ")
        for idx in worst:
            lines.append(f"  {entries.name(idx)}: got {fmt(got[idx], tiny, digits)}, "
                         f"{expected_name} {fmt(expected[idx], tiny, digits)}")
    lines.append(f"  ({tolerance_text(rtol, atol)}; largest difference {fmt(diff.max())})")
    mistake = diagnose(got, expected, mistakes, entries if expected_name == "expected" else None, rtol, atol)
    if mistake is not None:
        lines.insert(0, f"{label}: {mistake.help}")
        lines[1] = "  " + lines[1].replace(f"{label}: ", "", 1)
    return Verdict(False, "\n".join(lines), expected, got, {"wrong": np.argwhere(wrong).tolist()}, mistake)


def expect_raises(returned: Returned, exception: str, *, label: str, why: str = "") -> Verdict:
    """The call must raise `exception` (or a subclass of it)."""
    reason = f" ({why})" if why else ""
    if returned.kind == RAISED and exception in (returned.error or {}).get("bases", []):
        return Verdict(True)
    if returned.kind == RAISED:
        err = returned.error or {}
        return Verdict(False, f"{label} raised {err.get('exception')}: {err.get('message')}; "
                              f"expected {exception}{reason}.", details={"traceback": returned.traceback})
    if not returned.ok:
        return Verdict(False, returned.problem())
    value = returned.as_array()
    shown = fmt_array(value) if value is not None else returned.type_name
    return Verdict(False, f"{label} returned {shown}; expected it to raise {exception}{reason}.", got=value)


def all_of(verdicts: list[Verdict]) -> Verdict:
    """Pass when every verdict passes; otherwise the first failure, saying how many failed."""
    failures = [v for v in verdicts if not v.passed]
    if not failures:
        return Verdict(True, "", verdicts[-1].expected if verdicts else None, verdicts[-1].got if verdicts else None)
    first = next((f for f in failures if f.mistake is not None), failures[0])  # a named mistake says most
    if len(verdicts) > 1 and len({f.message for f in failures}) > 1 or len(failures) < len(verdicts):
        which = "the first" if first is failures[0] else "one of them"
        first.message = f"wrong at {len(failures)} of {len(verdicts)} inputs; {which}:\n{first.message}"
    return first


def fail(message: str, expected: object = None, got: object = None) -> Verdict:
    return Verdict(False, message, expected, got)


def passed(message: str = "", expected: object = None, got: object = None) -> Verdict:
    return Verdict(True, message, expected, got)
