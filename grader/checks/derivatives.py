"""Checks shared by every analytic derivative (tangent slope, gradient, J, H, F).

For a learner's derivative function D of a forward map f, at non-degenerate random points p:
- "matches the finite difference of the reference f": D(p) vs central differences of the
  reference forward map (this is also the check on further random inputs);
- "matches the finite difference of your own f": D(p) vs central differences of the learner's f,
  so feedback can tell "your H disagrees with your range_bearing in column 1" from "your
  range_bearing itself is wrong".

Tolerance. Step h_j = STEP * max(1, |p_j|). For a correct D the central difference differs by
at most h^2/6 * M3 (truncation; M3 bounds third derivatives, below 100 on the sampled domain where
r >= 0.5 and |p| <= 6, so <= 6e-8) plus eps * max|f| / h (rounding, about 3e-10): together below
1e-7. FD_ATOL + FD_RTOL * |expected| = 1e-6 + 1e-6*|.| leaves a margin of 10x. A sign slip,
transpose or missing term moves an entry by at least its own size, and the point generators keep
every nonzero entry of every derivative above MIN_ENTRY = 1e-3 in size (and a square
Jacobian that far from symmetric) (tests/checks/test_derivatives_tolerances.py checks both bounds
on every derivative and on such mutants), so no such error can hide under the tolerance.

The exact derivative (add_exact_check). Where the chapter's point is the derivative, one check asks
for it exact to rounding: |got - exact| <= EXACT_RTOL (|exact| + the largest entry), with no
single-precision floor. An analytic or autograd answer in float64 is off by a few units in the last
place (about 1e-15). A central difference is off by its truncation h^2 f'''/6 plus rounding eps |f| / h:
at least about eps^(2/3), 4e-11 of the derivative, whatever h (more near a singular point, where the
higher derivatives grow); a forward difference by at least about eps^(1/2). So a finite difference passed
off as the derivative fails, and is named. (The central difference of a quadratic, example_gradient,
bowl_gradient and g_jacobian, is exact in exact arithmetic: with a large step it passes, rightly.) A
float32 answer (jax's and torch's default) is off by about 1e-7 and gets the hint to compute in float64.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from grader.boundary.wire import Array, Returned, call
from grader.checks.base import ChapterChecks, Context, Skip
from grader.judging.compare import (
    Entries,
    Label,
    Verdict,
    all_of,
    compare_arrays,
    fmt,
    fmt_array,
    value_problem,
)
from grader.judging.diagnose import Evidence, Mistake

STEP = 1e-5
FD_RTOL = 1e-6
FD_ATOL = 1e-6
MIN_ENTRY = 1e-3  # every nonzero derivative entry at the sampled points is at least this large
INSIDE = 0.01  # points are drawn this far inside the contract's bounds, so finite-difference steps stay inside too
EXACT_RTOL = 1e-12  # the exact-derivative check, relative to the entry plus the largest entry
SINGLE_PRECISION_ERROR = 1e-5  # at most this far off (relatively) and in float32: a float32 answer
SINGLE_PRECISION_TRACE = 1e-9  # at least this far off: float32 arithmetic somewhere upstream is possible too
ROUNDED_DIGITS = 1e-3  # at most this far off (relatively): right to some digits only, as a finite difference is

REGISTERED: list = []  # every Derivative given to add_derivative_checks (tests/checks/test_derivatives_tolerances.py)

Case = tuple  # (point: np.ndarray of the differentiation variables, extra: tuple of other arguments)


@dataclass(frozen=True)
class Derivative:
    """A learner derivative function, the forward map it differentiates, and how to call both."""

    forward: str
    jacobian: str
    entries: Entries
    args: Callable[[np.ndarray, tuple], tuple]  # call arguments for (point, extra)
    reference_forward: Callable[[np.ndarray, tuple], np.ndarray]
    reference_jacobian: Callable[[np.ndarray, tuple], np.ndarray]
    cases: Callable[[np.random.Generator], list[Case]]  # non-degenerate random cases
    # call arguments of the learner's forward map at (point, extra), when they differ from `args`
    # (e.g. pipeline_jacobian(r, theta) checked against g_stage(polar_to_cartesian(r, theta)))
    forward_args: Callable[[np.ndarray, tuple], tuple] | None = None
    forward_text: str = ""  # how the forward map reads in messages, when not just `forward`
    # the derivative's own known mistakes at (point, extra), asked of the reference while planning
    mistakes: Callable[[np.ndarray, tuple], list] | None = None

    def forward_call(self, point: np.ndarray, extra: tuple):
        return call(self.forward, *(self.forward_args or self.args)(point, extra))

    @property
    def forward_name(self) -> str:
        return self.forward_text or self.forward

    def label(self, function: str, case: Case) -> Label:
        return call_label(function, self.args(*case))


def call_label(function: str, args: tuple) -> Label:
    """`function(arguments)` as messages show the call, written only if one does (most calls pass)."""
    return Label(lambda: f"{function}({', '.join(describe_argument(a) for a in args)})")


# Cases of the check against the learner's own forward map: each costs 2n + 2 learner calls, and a
# derivative inconsistent with its own map is so at almost every point (vs_reference tries all of them).
OWN_CASES = 3


def describe_argument(arg: object) -> str:
    if isinstance(arg, (list, tuple, np.ndarray)):
        return fmt_array(np.asarray(arg, dtype=float))
    if isinstance(arg, float):
        return fmt(arg)
    return repr(arg)


def steps(point: np.ndarray) -> np.ndarray:
    return STEP * np.maximum(1.0, np.abs(point))


def central_difference(f: Callable[[np.ndarray], np.ndarray], point: np.ndarray) -> np.ndarray:
    """Central-difference derivative: shape forward_shape + (n,)."""
    h = steps(point)
    columns = []
    for j in range(point.size):
        e = np.zeros_like(point)
        e[j] = h[j]
        columns.append((np.asarray(f(point + e), float) - np.asarray(f(point - e), float)) / (2 * h[j]))
    return np.stack(columns, axis=-1)


def _columns_text(wrong: list, entries: Entries) -> str:
    cols = sorted({idx[-1] for idx in wrong})
    names = [f"column {j}" + (f" (d/d {entries.cols[j]})" if j < len(entries.cols) else "") for j in cols]
    return ", ".join(names)


def add_derivative_checks(checks: ChapterChecks, d: Derivative, points: float = 2,
                          own_points: float = 1) -> None:
    """Register the two finite-difference checks of derivative `d` in `checks`."""
    REGISTERED.append(d)
    symbol = d.entries.symbol

    def vs_reference(ctx: Context):
        cases = d.cases(ctx.rng)
        expected = [central_difference(lambda p: d.reference_forward(p, case[1]), case[0]) for case in cases]
        slips = [d.mistakes(*case) if d.mistakes else [] for case in cases]
        got = yield [call(d.jacobian, *d.args(*case)) for case in cases]
        verdicts = []
        for case, returned, want, mistakes in zip(cases, got, expected, slips):
            label = d.label(d.jacobian, case)
            problem = value_problem(returned, want.shape, label)
            if problem:
                return Verdict(False, problem, want)
            v = compare_arrays(returned.as_array(), want, label=label, rtol=FD_RTOL, atol=FD_ATOL,
                               entries=d.entries, expected_name="expected", mistakes=mistakes, source=returned)
            if not v.passed:
                v.message = f"{v.message}\n  (wrong in {_columns_text(v.details['wrong'], d.entries)})"
            verdicts.append(v)
        return all_of(verdicts)

    vs_reference.__doc__ = f"{symbol} agrees with central differences of the reference {d.forward_name} at random points"
    checks.check(d.jacobian, points, id=f"{d.jacobian}_random_points")(vs_reference)

    def vs_own(ctx: Context):
        cases = d.cases(ctx.rng)[:OWN_CASES]
        forward_values = [np.asarray(d.reference_forward(point, extra), float) for point, extra in cases]
        wanted = []
        for point, extra in cases:
            h = steps(point)
            plus, minus = [], []
            for j in range(point.size):
                e = np.zeros_like(point)
                e[j] = h[j]
                plus.append(d.forward_call(point + e, extra))
                minus.append(d.forward_call(point - e, extra))
            wanted.append({"jac": call(d.jacobian, *d.args(point, extra)),
                           "at": d.forward_call(point, extra), "plus": plus, "minus": minus})
        got = yield wanted
        verdicts = []
        for (point, extra), g, forward_out in zip(cases, got, forward_values):
            label = d.label(d.jacobian, (point, extra))
            problem = value_problem(g["jac"], forward_out.shape + (point.size,), label)
            if problem:  # the derivative itself gives no value: its own failure, whatever the forward map does
                return Verdict(False, problem)
            for r in [g["at"], *g["plus"], *g["minus"]]:
                problem = value_problem(r, forward_out.shape, d.forward)
                if problem:
                    raise Skip(f"{problem} So {symbol} cannot be compared with the finite difference of your "
                               f"{d.forward_name}: not judged, no points lost; fix {d.forward} first.",
                               costs_nothing=True)
            if not np.allclose(g["at"].as_array(), forward_out, rtol=1e-9, atol=1e-12):
                raise Skip(f"your {d.forward_name} differs from the reference at {fmt_array(point)}, so its "
                           f"finite difference says nothing about your {symbol}: not judged, no points lost. Fix "
                           f"{d.forward} first (see its checks); {symbol} is still checked against the reference.",
                           costs_nothing=True)
            h = steps(point)
            fd = np.stack([(p.as_array() - m.as_array()) / (2 * h[j])
                           for j, (p, m) in enumerate(zip(g["plus"], g["minus"]))], axis=-1)
            v = compare_arrays(g["jac"].as_array(), fd, label=label, rtol=FD_RTOL, atol=FD_ATOL,
                               entries=d.entries, expected_name="finite difference of your " + d.forward_name)
            if not v.passed:
                v.message = (f"your {symbol} disagrees with the finite difference of your {d.forward_name} in "
                             f"{_columns_text(v.details['wrong'], d.entries)}; your {d.forward} matches the reference "
                             f"here, so the mistake is in {d.jacobian} (or in a function of yours it calls).\n"
                             f"{v.message}")
            verdicts.append(v)
        return all_of(verdicts)

    vs_own.__doc__ = f"{symbol} agrees with central differences of your own {d.forward_name}"
    checks.check(d.jacobian, own_points, id=f"{d.jacobian}_vs_own_{d.forward}")(vs_own)


# --------------------------------------------------------------------- the exact derivative

FLOAT64_HINT = ('compute in float64: jax.config.update("jax_enable_x64", True) before any jax call (with float '
                'inputs), or torch tensors of dtype=torch.float64')


def _single_precision(returned: Returned, got: np.ndarray) -> bool:
    """The learner's array is float32 (or float16), or every entry is a float32 number cast to float64."""
    dtype = str((returned.encoded or {}).get("dtype", ""))
    return dtype in ("float32", "float16") or bool(np.all(got.astype(np.float32).astype(np.float64) == got))


def exact_verdict(returned: Returned, exact: np.ndarray, label: "str | Label", entries: Entries) -> Verdict:
    """The learner's derivative against the exact one to rounding (EXACT_RTOL of the entry and of the largest
    entry), naming an answer right to single precision only and one right to some digits only (a finite
    difference)."""
    problem = value_problem(returned, exact.shape, label, entries.symbol)
    if problem:
        return Verdict(False, problem, exact)
    got = returned.as_array()
    scale = float(np.max(np.abs(exact)))
    verdict = compare_arrays(got, exact, label=label, rtol=EXACT_RTOL, atol=EXACT_RTOL * scale, entries=entries,
                             exact=True, expected_name="exact", digits=15, source=returned)
    if verdict.passed:
        return verdict
    worst = float(np.max(np.abs(got - exact) / (np.abs(exact) + scale))) if np.all(np.isfinite(got)) else np.inf
    if worst <= SINGLE_PRECISION_ERROR and _single_precision(returned, got):
        mistake = Mistake("single precision", f"your {entries.symbol} is right to single precision only (float32, "
                                              "jax's and torch's default); this check asks for the derivative right "
                                              f"to float64 rounding: {FLOAT64_HINT}.")
    elif worst <= ROUNDED_DIGITS:
        single = (f" (Or some of it is computed in single precision, float32: {FLOAT64_HINT}.)"
                  if worst >= SINGLE_PRECISION_TRACE else "")
        mistake = Mistake("finite difference", f"your {entries.symbol} agrees with the exact derivative to about "
                                               f"{max(1, int(-np.log10(worst)))} digits only, as a finite difference "
                                               "does: this check asks for the exact derivative (worked out by hand, or "
                                               "by autograd in float64), right to rounding where no finite difference "
                                               "is. A finite difference checks a derivative (chapter 5); it is not "
                                               f"one.{single}")
    else:
        return verdict
    return verdict.also(lambda only: Evidence({mistake.id: mistake}))


def add_exact_check(checks: ChapterChecks, function: str, entries: Entries,
                    cases: Callable[[np.random.Generator], list[tuple]], reference: Callable[..., np.ndarray],
                    where: str, points: float = 1) -> None:
    """Register `function`'s exact-derivative check: its values at `cases(rng)` (call arguments: random points
    and points `where` no finite difference reaches rounding) against `reference(*arguments)`."""
    def exact_check(ctx: Context):
        arguments = cases(ctx.rng)
        wanted = [np.asarray(reference(*args), dtype=float) for args in arguments]
        got = yield [call(function, *args) for args in arguments]
        return all_of([exact_verdict(g, want, call_label(function, args), entries)
                       for g, want, args in zip(got, wanted, arguments)])

    exact_check.__doc__ = (f"{entries.symbol} is the exact derivative, right to rounding (1e-12) at random points "
                           f"and {where}, where no finite difference is")
    checks.check(function, points, id=f"{function}_exact", exact_derivative=True)(exact_check)


# --------------------------------------------------------------------- non-degenerate inputs

def angle(rng: np.random.Generator) -> float:
    """An angle in (-pi, pi] at least 0.2 rad from every multiple of pi/4."""
    quadrant = rng.integers(-2, 2)
    offset = rng.choice([rng.uniform(0.2, 0.585), rng.uniform(0.985, 1.37)])
    return float(quadrant * np.pi / 2 + offset)


def elevation(rng: np.random.Generator, low: float = 0.2) -> float:
    """An angle above or below the horizon, |elevation| in [low, 1.37] (within the contract's 1.4), at least 0.2
    rad from 0 and from +-pi/4 when low is 0.2."""
    size = rng.choice([rng.uniform(low, 0.585), rng.uniform(max(low, 0.985), 1.37)]) if low < 0.585 else \
        rng.uniform(low, 1.37)
    return float(rng.choice([-1.0, 1.0]) * size)

def wound(value: float, rng: np.random.Generator) -> float:
    """An angle 12 to 20 whole turns further round (or back): the same direction, but a step that a finite
    difference adds to it is rounded there, so no finite difference is right to 1e-12 at it."""
    return float(value + 2 * np.pi * rng.integers(12, 21) * rng.choice([-1.0, 1.0]))

def planar_point(rng: np.random.Generator, r_min: float = 0.8, r_max: float = 4.5) -> np.ndarray:
    """A point (x, y) with r in [r_min, r_max] and its angle away from the axes and diagonals."""
    r = rng.uniform(r_min, r_max)
    theta = angle(rng)
    return r * np.array([np.cos(theta), np.sin(theta)])  # r times the unit vector at angle theta


def integer_point(rng: np.random.Generator) -> tuple[int, int]:
    """Integers (a, b), 1 to 99 in size with either sign and |a| != |b|: off the axes and diagonals (a sign or a
    transpose slip shows), and drawn for the run from some 39,000 pairs, so that a value read off one run's feedback
    hardly ever answers another."""
    while True:
        a, b = (int(rng.integers(1, 100)) * int(rng.choice([-1, 1])) for _ in range(2))
        if abs(a) != abs(b):
            return a, b


def polar_point(rng: np.random.Generator, r_max: float = 5.0) -> np.ndarray:
    """(r, theta) with r in [0.5, r_max] and theta away from the axes and diagonals."""
    return np.array([rng.uniform(0.5, r_max), angle(rng)])


def vector_form(values, form: str):
    """One vector as the contract lets it arrive: "tuple", "list", "array" or "int array"."""
    if form == "int array":
        return Array([int(v) for v in values], "int64")
    values = [float(v) for v in values]
    return {"tuple": tuple(values), "list": values, "array": np.array(values)}[form]


def time_step(rng: np.random.Generator) -> float:
    """A time step in [0.05, 0.5]: never 1, so a missing dt shows."""
    return float(rng.uniform(0.05, 0.5))
