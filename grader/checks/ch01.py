"""Chapter 1: the tangent line L(x) = f(a) + f'(a)(x - a) and how fast its error grows.

The functions f, f', f'' are catalogue callables (passed by name, elementwise on arrays), so the
derivative here is given, not computed by the learner: tangent_line is checked against
f(a) + f'(a)(x - a) directly. Values of these closed forms: rtol 1e-9 (they are a few flops).
The lesson's property: the error of the tangent line is 0.5 |f''(a)| delta^2 + O(delta^3), so the
log-log slope of linearization_error over delta = 0.4, 0.2, 0.1, 0.05 is 2 (1.93..2.06 at every
point these checks draw; accepted within 2 +- 0.15), and taylor_error_estimate matches the actual
error to 1% at delta = 1e-3 (the cubic term is below 0.1% there).
"""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import Array, Fn, call
from grader.catalogue import CALLABLES
from grader.checks.base import chapter_checks
from grader.judging.compare import (
    Entries,
    all_of,
    expect,
    fail,
    fmt,
    fmt_array,
    passed,
    value_problem,
)
from grader.judging.diagnose import Mistake
from grader.judging.expected import reference

CHECKS = chapter_checks("ch01")
REF = reference("ch01")

L = Entries("L")
ERROR = Entries("error")
SLOPE_DELTAS = (0.4, 0.2, 0.1, 0.05)
SLOPE_TOLERANCE = 0.15

# (f, f', f'') names from the catalogue; None where the catalogue has no f''.
FUNCTIONS = {
    "sqrt": ("sqrt", "sqrt_prime", "sqrt_second"),
    "sin": ("sin", "cos", "neg_sin"),
    "cubic": ("cubic", "cubic_prime", "cubic_second"),
    "exp": ("exp", "exp", "exp"),
    "log": ("log", "reciprocal", None),
}


def _sin_point(rng: np.random.Generator) -> float:
    """|sin a| >= 0.71 and |cos a| >= 0.27: f'(a) and f''(a) both clearly nonzero."""
    return float(rng.choice([-1, 1]) * rng.choice([rng.uniform(0.8, 1.3), rng.uniform(1.85, 2.35)]))


def _point(rng: np.random.Generator, function: str) -> float:
    """A point where f, f' and f'' are all well away from 0 (and inside the domain)."""
    if function == "sin":
        return _sin_point(rng)
    if function == "cubic":  # f' = 3a^2 - 2 and f'' = 6a: |a| in [1.1, 2]
        return float(rng.choice([-1, 1]) * rng.uniform(1.1, 2.0))
    if function == "exp":
        return float(rng.uniform(-1.0, 1.0))
    return float(rng.uniform(2.0, 6.0))  # sqrt, log


def _offsets(rng: np.random.Generator, k: int) -> np.ndarray:
    """k steps x - a of both signs, 0.3 <= |x - a| <= 1.5 (never 1)."""
    size = np.where(rng.random(k) < 0.5, rng.uniform(0.3, 0.9, k), rng.uniform(1.1, 1.5, k))
    return rng.choice([-1.0, 1.0], size=k) * size


def _cases(rng: np.random.Generator) -> list:
    """(function, a, x, x as passed): every catalogue function once, x a float or an array."""
    cases = []
    for i, function in enumerate(["sqrt", "sin", "cubic", "exp", "log", "sqrt"]):
        a = _point(rng, function)
        if i % 2:
            x = a + _offsets(rng, 4)
            cases.append((function, a, x, Array(x.tolist())))
        else:
            x = float(a + _offsets(rng, 1)[0])
            cases.append((function, a, x, x))
    return cases


def _label(function: str, names: tuple, a, x) -> str:
    shown = fmt_array(x) if isinstance(x, np.ndarray) else fmt(x)
    return f"{function}(f={names[0]}, fprime={names[1]}, a={fmt(a)}, x={shown})"


@CHECKS.check("tangent_line", points=1)
def tangent_line_worked_example(ctx):
    """tangent_line of sqrt at a=4: L(5) = 2 + (1/4)(5 - 4) = 2.25"""
    got = yield call("tangent_line", Fn("sqrt"), Fn("sqrt_prime"), 4, 5)
    return expect(got, 2.25, label="tangent_line(sqrt, sqrt_prime, a=4, x=5)", rtol=1e-12, entries=L)


@CHECKS.check("tangent_line", points=2)
def tangent_line_random_inputs(ctx):
    """tangent_line = f(a) + f'(a)(x - a) for sqrt, sin, a cubic, exp and log at random a, x (floats and arrays)"""
    cases = _cases(ctx.rng)
    expected = [REF.tangent_of(*FUNCTIONS[fn][:2], a, x) for fn, a, x, _ in cases]
    slips = [REF.tangent_mistakes_of(*FUNCTIONS[fn][:2], a, x) for fn, a, x, _ in cases]
    got = yield [call("tangent_line", Fn(FUNCTIONS[fn][0]), Fn(FUNCTIONS[fn][1]), a, passed_x)
                 for fn, a, x, passed_x in cases]
    return all_of([expect(g, want, label=_label("tangent_line", FUNCTIONS[fn], a, x), rtol=1e-9, atol=1e-12, entries=L,
                          mistakes=[Mistake("slope at x", "the slope is taken at x: use fprime(a), the slope at the "
                                                          "point of tangency.", slip["slope at x"])])
                   for g, want, slip, (fn, a, x, _) in zip(got, expected, slips, cases)])


@CHECKS.check("linearization_error", points=2)
def linearization_error_worked_example(ctx):
    """linearization_error of sqrt at a=4, x = 4.5, 5, 6, 8 is 0.003680, 0.013932, 0.050510, 0.171573"""
    got = yield {"array": call("linearization_error", Fn("sqrt"), Fn("sqrt_prime"), 4, Array([4.5, 5, 6, 8])),
                 "float": call("linearization_error", Fn("sqrt"), Fn("sqrt_prime"), 4, 5.0)}
    # the lesson gives 6 decimals: accept anything that rounds to them
    return all_of([
        expect(got["array"], [0.003680, 0.013932, 0.050510, 0.171573], rtol=0.0, atol=5e-7, entries=ERROR,
               label="linearization_error(sqrt, sqrt_prime, a=4, x=np.array([4.5, 5, 6, 8]))"),
        expect(got["float"], 0.013932, rtol=0.0, atol=5e-7, entries=ERROR,
               label="linearization_error(sqrt, sqrt_prime, a=4, x=5.0)"),
    ])


@CHECKS.check("linearization_error", points=2)
def linearization_error_random_inputs(ctx):
    """linearization_error = |f(x) - L(x)| (never negative) for several f at random a, x (floats and arrays)"""
    cases = _cases(ctx.rng)
    expected = [REF.error_of(*FUNCTIONS[fn][:2], a, x) for fn, a, x, _ in cases]
    signed = [REF.signed_error_of(*FUNCTIONS[fn][:2], a, x) for fn, a, x, _ in cases]
    got = yield [call("linearization_error", Fn(FUNCTIONS[fn][0]), Fn(FUNCTIONS[fn][1]), a, passed_x)
                 for fn, a, x, passed_x in cases]
    return all_of([expect(g, want, rtol=1e-9, atol=1e-12, entries=ERROR,
                          label=_label("linearization_error", FUNCTIONS[fn], a, x),
                          mistakes=[Mistake("signed error", "the error is |f(x) - L(x)|: take the absolute value.",
                                            value), _relative_error(fn, x, want)])
                   for g, want, value, (fn, a, x, _) in zip(got, expected, signed, cases)])


def _relative_error(fn: str, x, error) -> Mistake:
    """The error relative to |f(x)|, where the absolute one is asked."""
    with np.errstate(divide="ignore", invalid="ignore"):
        value = np.asarray(error, dtype=float) / np.abs(CALLABLES[FUNCTIONS[fn][0]](np.asarray(x, dtype=float)))
    return Mistake("relative error", "that is the error relative to |f(x)|: linearization_error is the absolute "
                                     "error |f(x) - L(x)|, not divided by anything.", value)


@CHECKS.check("linearization_error", points=1)
def linearization_error_grows_like_delta_squared(ctx):
    """halving delta = x - a quarters the tangent-line error: the log-log slope of linearization_error is 2"""
    rng = ctx.rng
    deltas = np.array(SLOPE_DELTAS)
    cases = [(fn, _point(rng, fn), float(rng.choice([-1, 1]))) for fn in ("cubic", "sin", "sqrt")]
    got = yield [call("linearization_error", Fn(FUNCTIONS[fn][0]), Fn(FUNCTIONS[fn][1]), a, Array((a + side * deltas).tolist()))
                 for fn, a, side in cases]
    for g, (fn, a, side) in zip(got, cases):
        x = a + side * deltas
        label = _label("linearization_error", FUNCTIONS[fn], a, x)
        problem = value_problem(g, deltas.shape, label)
        if problem:
            return fail(problem)
        errors = g.as_array()
        if not np.all(np.isfinite(errors)) or np.any(errors <= 0):
            return fail(f"{label} returned {fmt_array(errors)}: the errors must be positive to fit a log-log slope.",
                        got=errors)
        slope = float(np.polyfit(np.log(deltas), np.log(errors), 1)[0])
        if abs(slope - 2.0) > SLOPE_TOLERANCE:
            return fail(f"{label} = {fmt_array(errors)}: for |x - a| = {', '.join(fmt(d) for d in deltas)} the "
                        f"log-log slope is {slope:.3f}; the tangent-line error should grow like delta^2 "
                        f"(slope 2 +- {SLOPE_TOLERANCE:g}).", expected=2.0, got=slope)
    return passed()


@CHECKS.check("taylor_error_estimate", points=1)
def taylor_error_estimate_worked_example(ctx):
    """taylor_error_estimate for sqrt at a=4, delta=1 is 0.5 * |-1/32| * 1 = 1/64"""
    got = yield call("taylor_error_estimate", Fn("sqrt_second"), 4, 1)
    return expect(got, 1 / 64, label="taylor_error_estimate(sqrt_second, a=4, delta=1)", rtol=1e-12)


@CHECKS.check("taylor_error_estimate", points=1)
def taylor_error_estimate_random_inputs(ctx):
    """taylor_error_estimate = 0.5 |f''(a)| delta^2 at random a and delta (f'' of either sign, delta of either sign)"""
    rng = ctx.rng
    cases = [(fn, _point(rng, fn), float(_offsets(rng, 1)[0])) for fn in ("sqrt", "sin", "cubic", "exp", "sin")]
    expected = [REF.estimate_of(FUNCTIONS[fn][2], a, delta) for fn, a, delta in cases]
    got = yield [call("taylor_error_estimate", Fn(FUNCTIONS[fn][2]), a, delta) for fn, a, delta in cases]
    return all_of([expect(g, want, rtol=1e-9, atol=1e-12, mistakes=[
        Mistake("missing 0.5", "the estimate is 0.5 |f''(a)| delta^2: the factor 0.5 is missing.", 2 * want),
        Mistake("delta not squared", "delta is not squared: the estimate is 0.5 |f''(a)| delta^2.", want / abs(delta)),
        Mistake("delta not squared", "delta is not squared: the estimate is 0.5 |f''(a)| delta^2.", want / delta),
        Mistake("f'' at a + delta", "f'' is taken at a + delta: the estimate uses the curvature at a, "
                                    "0.5 |f''(a)| delta^2.",
                0.5 * abs(float(CALLABLES[FUNCTIONS[fn][2]](a + delta))) * delta * delta)],
                          label=f"taylor_error_estimate({FUNCTIONS[fn][2]}, a={fmt(a)}, delta={fmt(delta)})")
                   for g, want, (fn, a, delta) in zip(got, expected, cases)])


@CHECKS.check("taylor_error_estimate", points=1)
def taylor_error_estimate_matches_actual_error(ctx):
    """for small delta (1e-3) taylor_error_estimate matches the tangent line's actual error |f(a+delta) - L(a+delta)| to 1%"""
    rng = ctx.rng
    cases = [(fn, _point(rng, fn), float(rng.choice([-1, 1]) * 1e-3)) for fn in ("sqrt", "sin", "cubic", "exp")]
    actual = [REF.error_of(*FUNCTIONS[fn][:2], a, a + delta) for fn, a, delta in cases]
    got = yield [call("taylor_error_estimate", Fn(FUNCTIONS[fn][2]), a, delta) for fn, a, delta in cases]
    return all_of([expect(g, want, rtol=1e-2, atol=0.0,
                          label=f"taylor_error_estimate({FUNCTIONS[fn][2]}, a={fmt(a)}, delta={fmt(delta)}) "
                                f"vs the actual error of the tangent line of {fn}")
                   for g, want, (fn, a, delta) in zip(got, actual, cases)])
