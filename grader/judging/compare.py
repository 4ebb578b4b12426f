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
from grader.judging.diagnose import (
    SMALL,
    Evidence,
    Mistake,
    combined,
    explain,
    generated,
    generic,
    shape_mistake,
    weigh,
    within,
)
from grader.judging.relations import relations, tight
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
    mistake: Mistake | None = None  # the known mistake the wrong value matches (grader.judging.diagnose)
    help: str = ""  # what to change (the named mistake's sentence), apart from the message, which says what is wrong
    # what this comparison says of each candidate mistake (grader.judging.diagnose), worked out only when a check's failure
    # asks: evidence(None) of every candidate, evidence(ids) of those candidates only (the others not evaluated)
    evidence: Callable[[set[str] | None], Evidence] | None = field(default=None, repr=False, compare=False)
    explained: bool = field(default=False, init=False, repr=False, compare=False)  # its mistake is decided
    _weighed: Evidence | None = field(default=None, init=False, repr=False, compare=False)

    def weigh(self, only: set[str] | None = None) -> Evidence | None:
        """What this comparison says of each candidate mistake (of those in `only`, if given: the slips generated
        from the reference are then evaluated for these only); None for a failure no mistake can explain (one
        with neither a comparison of values nor a mistake of its own)."""
        if self._weighed is not None:
            return self._weighed
        if self.evidence is not None:
            if only is not None:
                return self.evidence(only)
            self._weighed = self.evidence(None)
        elif self.mistake is not None:
            self._weighed = Evidence({self.mistake.id: self.mistake})
        elif self.passed:
            self._weighed = Evidence()
        return self._weighed

    def also(self, extra: Callable[[set[str] | None], Evidence]) -> Verdict:
        """This verdict with more evidence (e.g. the generated slips of the raw value a derived comparison was
        made of, or a mistake of the check's own), its failure to be named from all of it."""
        own, mistake = self.evidence, self.mistake

        def both(only: set[str] | None) -> Evidence:
            first = own(only) if own is not None else Evidence({mistake.id: mistake} if mistake is not None else {})
            second = extra(only)
            ruled = first.ruled_out | second.ruled_out  # told apart anywhere: not this slip
            return Evidence({k: m for k, m in {**first.matched, **second.matched}.items() if k not in ruled}, ruled)
        self.evidence, self._weighed, self.explained = both, None, False
        return self

    def name(self, mistake: Mistake | None) -> None:
        """Name `mistake` (or none) as what this failure is: its help goes apart from the message."""
        self.mistake, self.help, self.explained = mistake, mistake.help if mistake is not None else "", True

    def explain(self) -> Verdict:
        """Name what this failure is, if not done yet: the mistake its comparison explains (grader.judging.diagnose)."""
        if not self.passed and not self.explained:
            self.name(explain([self.weigh()]))
        return self


@dataclass(frozen=True)
class Entries:
    """How to name the entries of a result: `H[1,0] = d bearing/d x` or `z[1] (bearing)`."""

    symbol: str
    rows: tuple[str, ...] = ()
    cols: tuple[str, ...] = ()
    derivative: bool = False
    product: bool = False  # a product A M A^T (a covariance carried through A): another square size is its order

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
    """One comparison of values as a check made it, for whoever watches (grade selftest, grader.course.selftest): the right
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
                  symbol: str = "result", with_help: bool = True) -> str | None:
    """Why `returned` cannot be compared to a result of `expected_shape`, or None if it can (with the help for a
    wrong shape with the right entries, unless `with_help` is False: the caller gives it apart)."""
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
            (f" {mistake.help[0].upper()}{mistake.help[1:]}" if mistake and with_help else "")
    return None


def expect(returned: Returned, expected: object, *, label: str | Label, rtol: float = 1e-6,
           atol: float = 1e-9, entries: Entries | None = None, mistakes: tuple | list = (),
           exact: bool = False) -> Verdict:
    """Compare a learner's returned value with the expected number or array (see compare_arrays); a
    wrong value is named by the first of `mistakes` (then of the generic slips, the relations, then the slips
    generated from the reference at this very call) it matches."""
    expected = np.asarray(expected, dtype=np.float64)
    symbol = (entries or Entries("result")).symbol
    problem = value_problem(returned, expected.shape, label, symbol, with_help=False)
    if problem is not None:
        got = returned.as_array() if returned.ok else None
        verdict = Verdict(False, problem, expected=expected,
                          details={"traceback": returned.traceback} if returned.traceback else {})
        verdict.name(shape_mistake(got.shape, expected.shape, symbol, bool(entries and entries.product))
                     if got is not None else None)
        return verdict
    return compare_arrays(returned.as_array(), expected, label=label, rtol=rtol, atol=atol, entries=entries,
                          mistakes=mistakes, exact=exact, source=returned)


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
                   digits: int = 6, source: Returned | None = None) -> Verdict:
    """Values of two float arrays of the same shape, with the worst entries named (to `digits` significant
    digits), and the mistake the wrong value matches (grader.judging.diagnose) as the verdict's help. Any real dtype
    is a right answer (the contract): unless `exact` (a check telling apart values closer than that, e.g.
    finite-difference conventions), the tolerance is at least single-precision round-off relative to the
    result's scale, so that float32 (jax's and torch's default), there or anywhere upstream, is right.
    `source`: the learner's Returned whose value `got` is, so that the slips generated from the reference at
    that call are candidates too."""
    got = np.asarray(got, dtype=np.float64)
    expected = np.asarray(expected, dtype=np.float64)
    if got.shape != expected.shape:
        return Verdict(False, f"{label}: shape {got.shape}, expected {expected.shape}.", expected, got)
    named_entries = (entries or Entries("result")) if expected_name == "expected" else None
    observer = _OBSERVER.get()
    if observer is not None:  # grade selftest: what this comparison could tell apart
        observer(Comparison(expected, rtol, atol, exact, tuple(mistakes), named_entries, source))

    def evidence(only: set[str] | None = None) -> Evidence:
        low, high = _tolerance(expected, rtol, atol, exact)
        candidates = [*mistakes, *(generic(expected, named_entries) if named_entries is not None else []),
                      *(relations(got, expected, named_entries)
                        if named_entries is not None and tight(expected, low, high) else []),
                      *(generated(source, only) if source is not None else [])]
        return weigh(got, expected, candidates, low, high)

    if got.size <= SMALL and _all_within(got.ravel().tolist(), expected.ravel().tolist(), rtol, atol, exact):
        return Verdict(True, "", expected, got, evidence=evidence)
    rtol, atol = _tolerance(expected, rtol, atol, exact)
    tiny = atol / 10  # below a tenth of the tolerance a number reads as 0, in this message and in the report's matrices
    shown = {"zero_below": tiny, "digits": digits}  # how the renderers write got and expected: as the message does
    entries = entries or Entries("result")
    bad_got = ~np.isfinite(got)
    if bad_got.any() and not np.array_equal(bad_got, ~np.isfinite(expected)):
        where = [entries.name(tuple(int(i) for i in idx)) for idx in np.argwhere(bad_got)[:SHOWN_ENTRIES]]
        if got.ndim == 0:
            where = [entries.symbol]
        verdict = Verdict(False, f"{label} is not finite: {', '.join(where)} = "
                                 f"{fmt(got[tuple(np.argwhere(bad_got)[0])])}.", expected, got,
                          {"wrong": np.argwhere(bad_got).tolist(), **shown}, evidence=evidence)
        return verdict  # its mistake is named when asked (Verdict.explain, all_of): the slips are weighed then
    diff = np.asarray(np.abs(got - expected))  # an array even for scalars (numpy returns a float64 there)
    diff[np.isnan(diff) & np.isnan(got) & np.isnan(expected)] = 0.0
    limit = atol + rtol * np.abs(expected)
    wrong = ~(diff <= limit)
    if not wrong.any():
        return Verdict(True, "", expected, got, evidence=evidence)
    order = np.argsort(-np.where(wrong, diff, -1.0), axis=None, kind="stable")
    worst = [tuple(int(i) for i in np.unravel_index(k, got.shape)) for k in order[: min(SHOWN_ENTRIES, int(wrong.sum()))]]
    lines = []
    if got.ndim == 0:
        lines.append(f"{label}: got {fmt(got, tiny, digits)}, {expected_name} {fmt(expected, tiny, digits)}")
    else:
        lines.append(f"{label}: {int(wrong.sum())} of {got.size} entries differ")
        for idx in worst:
            lines.append(f"  {entries.name(idx)}: got {fmt(got[idx], tiny, digits)}, "
                         f"{expected_name} {fmt(expected[idx], tiny, digits)}")
    lines.append(f"  ({tolerance_text(rtol, atol)}; largest difference {fmt(diff.max())})")
    return Verdict(False, "\n".join(lines), expected, got, {"wrong": np.argwhere(wrong).tolist(), **shown},
                   evidence=evidence)  # its mistake is named when asked (Verdict.explain, all_of)


def _tolerance(expected: np.ndarray, rtol: float, atol: float, exact: bool) -> tuple[float, float]:
    """The tolerance compare_arrays applies: with the single-precision floor unless `exact`."""
    if exact:
        return rtol, atol
    scale = float(np.max(np.abs(expected[np.isfinite(expected)]), initial=0.0))
    return max(rtol, SINGLE_PRECISION), max(atol, SINGLE_PRECISION * scale)


def exactly(returned: Returned, right: object = None, rtol: float = 1e-9,
            atol: float = 1e-12) -> Callable[[set[str] | None], Evidence]:
    """The evidence of the slips generated from the reference at the call that returned `returned`, its value
    weighed against theirs to `rtol` and `atol`: for a check that judges by another measure (a statistical
    tolerance, a derived quantity), since a slip reproduces its value exactly from the same inputs and seed.
    `right`: the right value there, if known (a slip equal to it says nothing)."""
    def evidence(only: set[str] | None = None) -> Evidence:
        got = returned.as_array() if returned.ok else None
        if got is None:
            return Evidence()
        want = np.full(got.shape, np.nan) if right is None else np.asarray(right, dtype=float)
        return weigh(np.asarray(got, dtype=float), want, generated(returned, only), rtol, atol)
    return evidence


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
    verdict = Verdict(False, f"{label} returned {shown}; expected it to raise {exception}{reason}.", got=value)
    verdict.name(Mistake(f"no {exception}", f"check for this input first and raise {exception} there: a value "
                                            "computed where the function is undefined (NaN, inf or a number) is not "
                                            "an answer."))
    return verdict


def all_of(verdicts: list[Verdict]) -> Verdict:
    """Pass when every verdict passes; otherwise the first failure, saying how many failed, with the mistake
    that explains every failure (and is told apart at none of the passing inputs), if one does."""
    failures = [v for v in verdicts if not v.passed]
    if not failures:
        return Verdict(True, "", verdicts[-1].expected if verdicts else None, verdicts[-1].got if verdicts else None)
    first = failures[0]
    # every candidate at the first failure; at the others only those still matched everywhere (only what is needed
    # is evaluated of the slips generated from the reference)
    failing = [first.weigh()]
    common = set(failing[0].matched) if failing[0] is not None else set()
    for failure in failures[1:]:
        if not common:
            break
        evidence = failure.weigh(common)
        failing.append(evidence)
        common &= set(evidence.matched) if evidence is not None else set()
    passing = [v for v in verdicts if v.passed]
    first.name(explain(failing, (v.weigh(common) for v in passing)) if common else None)
    if first.mistake is not None:  # the inputs' evidence as one, for a check made of checks
        first._weighed = combined(failing, [e for e in (v.weigh(common) for v in passing) if e is not None])
    else:
        first._weighed = Evidence()  # nothing explains these failures
    if len(verdicts) > 1 and len({f.message for f in failures}) > 1 or len(failures) < len(verdicts):
        first.message = f"wrong at {len(failures)} of {len(verdicts)} inputs; the first:\n{first.message}"
    return first


def fail(message: str, expected: object = None, got: object = None) -> Verdict:
    return Verdict(False, message, expected, got)


def passed(message: str = "", expected: object = None, got: object = None) -> Verdict:
    return Verdict(True, message, expected, got)
