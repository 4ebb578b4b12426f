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
Jacobian that far from symmetric) (tests/test_tolerances.py checks both bounds
on every derivative and on such mutants), so no such error can hide under the tolerance.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from grader.checks.base import ChapterChecks, Context, Skip
from grader.compare import Entries, Verdict, all_of, compare_arrays, fmt, fmt_array, value_problem
from grader.wire import Array, call

STEP = 1e-5
FD_RTOL = 1e-6
FD_ATOL = 1e-6
MIN_ENTRY = 1e-3  # every nonzero derivative entry at the sampled points is at least this large

REGISTERED: list = []  # every Derivative given to add_derivative_checks (tests/test_tolerances.py)

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

    def label(self, function: str, case: Case) -> str:
        return f"{function}({', '.join(describe_argument(a) for a in self.args(*case))})"


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
                               entries=d.entries, expected_name="expected", mistakes=mistakes)
            if not v.passed:
                v.message = f"{v.message}\n  (wrong in {_columns_text(v.details['wrong'], d.entries)})"
            verdicts.append(v)
        return all_of(verdicts)

    vs_reference.__doc__ = f"{symbol} agrees with central differences of the reference {d.forward_name} at random points"
    checks.check(d.jacobian, points, id=f"{d.jacobian}_random_points")(vs_reference)

    def vs_own(ctx: Context):
        cases = d.cases(ctx.rng)
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


# --------------------------------------------------------------------- non-degenerate inputs

def angle(rng: np.random.Generator) -> float:
    """An angle in (-pi, pi] at least 0.2 rad from every multiple of pi/4."""
    quadrant = rng.integers(-2, 2)
    offset = rng.choice([rng.uniform(0.2, 0.585), rng.uniform(0.985, 1.37)])
    return float(quadrant * np.pi / 2 + offset)


def planar_point(rng: np.random.Generator, r_min: float = 0.8, r_max: float = 4.5) -> np.ndarray:
    """A point (x, y) with r in [r_min, r_max] and its angle away from the axes and diagonals."""
    r = rng.uniform(r_min, r_max)
    theta = angle(rng)
    return r * np.array([np.cos(theta), np.sin(theta)])  # r times the unit vector at angle theta


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
