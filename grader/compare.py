"""Every numeric comparison and its message, in one place.

Order of the sanity checks (after PrairieLearn's code_feedback and numpy.testing): did the call
give a value at all -> is it the right type (plain ndarray or real number) -> shape -> finite ->
values within `atol + rtol * |expected|`, naming the worst entries.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from grader.wire import RAISED, Returned

SHOWN_ENTRIES = 3


@dataclass
class Verdict:
    """A check's outcome before points are attached."""

    passed: bool
    message: str = ""
    expected: object = None
    got: object = None
    details: dict = field(default_factory=dict)


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


def fmt(value: float) -> str:
    """A number as a learner reads it: up to 6 significant digits."""
    value = float(value)
    if value == 0:
        return "0"
    return f"{value:.6g}"


def fmt_array(values: np.ndarray) -> str:
    values = np.asarray(values, dtype=float)
    if values.ndim == 0:
        return fmt(values)
    return np.array2string(values, precision=6, separator=", ", suppress_small=False,
                           formatter={"float_kind": fmt})


def tolerance_text(rtol: float, atol: float) -> str:
    return f"tolerance |got - expected| <= {atol:g} + {rtol:g}*|expected|"


def value_problem(returned: Returned, expected_shape: tuple[int, ...], label: str) -> str | None:
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
        return f"{label} returned shape {got.shape}; expected shape {expected_shape}."
    return None


def expect(returned: Returned, expected: object, *, label: str, rtol: float = 1e-6,
           atol: float = 1e-9, entries: Entries | None = None) -> Verdict:
    """Compare a learner's returned value with the expected number or array."""
    expected = np.asarray(expected, dtype=np.float64)
    problem = value_problem(returned, expected.shape, label)
    if problem is not None:
        return Verdict(False, problem, expected=expected,
                       details={"traceback": returned.traceback} if returned.traceback else {})
    return compare_arrays(returned.as_array(), expected, label=label, rtol=rtol, atol=atol, entries=entries)


def compare_arrays(got: np.ndarray, expected: np.ndarray, *, label: str, rtol: float = 1e-6,
                   atol: float = 1e-9, entries: Entries | None = None,
                   expected_name: str = "expected") -> Verdict:
    """Values of two float arrays of the same shape, with the worst entries named."""
    got = np.asarray(got, dtype=np.float64)
    expected = np.asarray(expected, dtype=np.float64)
    if got.shape != expected.shape:
        return Verdict(False, f"{label}: shape {got.shape}, expected {expected.shape}.", expected, got)
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
    if got.ndim == 0:
        lines.append(f"{label}: got {fmt(got)}, {expected_name} {fmt(expected)}")
    else:
        lines.append(f"{label}: {int(wrong.sum())} of {got.size} entries differ")
        for idx in worst:
            lines.append(f"  {entries.name(idx)}: got {fmt(got[idx])}, {expected_name} {fmt(expected[idx])}")
    lines.append(f"  ({tolerance_text(rtol, atol)}; largest difference {fmt(diff.max())})")
    return Verdict(False, "\n".join(lines), expected, got, {"wrong": np.argwhere(wrong).tolist()})


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
    first = failures[0]
    if len(verdicts) > 1 and len({f.message for f in failures}) > 1 or len(failures) < len(verdicts):
        first.message = f"wrong at {len(failures)} of {len(verdicts)} inputs; the first:\n{first.message}"
    return first


def fail(message: str, expected: object = None, got: object = None) -> Verdict:
    return Verdict(False, message, expected, got)


def passed(message: str = "", expected: object = None, got: object = None) -> Verdict:
    return Verdict(True, message, expected, got)
