"""Chapter 0: the range sensor r = sqrt(x^2 + y^2) is not linear, and noise shifts its mean.

mean_shift samples, so it is graded statistically: for R = |N(m, sigma^2 I)| with |m| = r the exact
mean and variance are known (R is Rice distributed), and the learner's sample mean over n draws
must lie within 5 standard errors, 5 sqrt(Var R / n), of E[R] - r. A correct function fails that
with probability below 1e-6; dropping the "- range(mean)", taking the range of the mean sample
or scaling the noise by sigma^2 moves the result by 6 or more standard errors at the inputs drawn.
Closed forms (range, superposition gap) are compared with rtol 1e-9.
"""

from __future__ import annotations

import numpy as np

from grader.checks.base import chapter_checks
from grader.checks.derivatives import planar_point, vector_form
from grader.checks.sampling import same_seed_same_value
from grader.compare import all_of, compare_arrays, expect, fail, fmt, value_problem
from grader.wire import call

CHECKS = chapter_checks("ch00")

STANDARD_ERRORS = 5.0


def rice_moments(r: float, sigma: float) -> tuple[float, float]:
    """E[R] and Var[R] for R = |m + sigma Z|, Z standard normal in 2-D, |m| = r.

    E[R] = sigma sqrt(pi/2) e^-t ((1 + 2t) I0(t) + 2t I1(t)) with t = r^2 / (4 sigma^2); the scaled
    Bessel functions e^-t I_k(t) = (1/pi) int_0^pi e^(t (cos u - 1)) cos(k u) du are integrated by
    the trapezoid rule, exact to rounding for this smooth periodic integrand.
    """
    t = r * r / (4 * sigma * sigma)
    u = np.linspace(0.0, np.pi, 4001)
    weights = np.full(u.size, 1.0 / (u.size - 1))
    weights[[0, -1]] *= 0.5
    base = np.exp(t * (np.cos(u) - 1.0))
    i0, i1 = float(weights @ base), float(weights @ (base * np.cos(u)))
    mean = sigma * np.sqrt(np.pi / 2) * ((1 + 2 * t) * i0 + 2 * t * i1)
    return float(mean), float(2 * sigma * sigma + r * r - mean * mean)


def _show(values) -> str:
    return "(" + ", ".join(fmt(v) for v in values) + ")"


@CHECKS.check("range_reading", points=1)
def range_reading_worked_example(ctx):
    """range_reading(3, 4) is 5"""
    got = yield call("range_reading", 3, 4)
    return expect(got, 5.0, label="range_reading(3, 4)", rtol=1e-12)


@CHECKS.check("range_reading", points=1)
def range_reading_random_points(ctx):
    """range_reading = sqrt(x^2 + y^2) at random points in all four quadrants, and at integers"""
    points = [planar_point(ctx.rng) for _ in range(6)]
    got = yield {"float": [call("range_reading", float(x), float(y)) for x, y in points],
                 "int": call("range_reading", -5, 12)}
    verdicts = [expect(g, np.hypot(x, y), label=f"range_reading({fmt(x)}, {fmt(y)})", rtol=1e-9)
                for g, (x, y) in zip(got["float"], points)]
    verdicts.append(expect(got["int"], 13.0, label="range_reading(-5, 12)", rtol=1e-12))
    return all_of(verdicts)


@CHECKS.check("superposition_gap", points=1)
def superposition_gap_worked_example(ctx):
    """superposition_gap((3, 0), (0, 4)) is 5 - (3 + 4) = -2"""
    got = yield call("superposition_gap", (3, 0), (0, 4))
    return expect(got, -2.0, label="superposition_gap((3, 0), (0, 4))", rtol=1e-12)


@CHECKS.check("superposition_gap", points=2)
def superposition_gap_random_points(ctx):
    """superposition_gap = range(p + q) - (range(p) + range(q)) is nonzero for random p, q (tuples, lists, arrays)"""
    rng = ctx.rng
    forms = ["tuple", "list", "array", "tuple", "array", "list"]
    cases = []
    for form in forms:
        p, q = planar_point(rng), planar_point(rng)
        while np.hypot(*(p + q)) - np.hypot(*p) - np.hypot(*q) > -0.1:  # p, q not nearly parallel
            q = planar_point(rng)
        cases.append((p, q, form))
    got = yield [call("superposition_gap", vector_form(p, form), vector_form(q, form)) for p, q, form in cases]
    verdicts = []
    for g, (p, q, form) in zip(got, cases):
        expected = np.hypot(*(p + q)) - np.hypot(*p) - np.hypot(*q)
        label = f"superposition_gap({_show(p)}, {_show(q)}) with {form}s"
        verdicts.append(expect(g, expected, label=label, rtol=1e-9, atol=1e-12))
    return all_of(verdicts)


def _shift_verdict(returned, mean, sigma: float, n: int, label: str):
    """Within STANDARD_ERRORS standard errors of the exact mean shift E[R] - r."""
    problem = value_problem(returned, (), label)
    if problem:
        return fail(problem)
    r = float(np.hypot(*mean))
    expected_range, variance = rice_moments(r, sigma)
    expected = expected_range - r
    tolerance = STANDARD_ERRORS * np.sqrt(variance / n)
    return compare_arrays(returned.as_array(), expected, label=f"{label} (about sigma^2/(2r) = "
                          f"{fmt(sigma * sigma / (2 * r))}; statistical, {STANDARD_ERRORS:g} standard errors)",
                          rtol=0.0, atol=float(tolerance))


@CHECKS.check("mean_shift", points=2)
def mean_shift_worked_example(ctx):
    """mean_shift((3, 4), sigma=1, n=100000) is about 0.10: the cloud's mean range moves outward"""
    got = yield call("mean_shift", (3, 4), 1.0, 100_000, 0)
    return _shift_verdict(got, (3.0, 4.0), 1.0, 100_000, "mean_shift((3, 4), 1, 100000, seed=0)")


@CHECKS.check("mean_shift", points=2)
def mean_shift_random_inputs(ctx):
    """mean_shift matches the exact shift E[range] - range(mean) at random means, sigmas and seeds"""
    rng = ctx.rng
    forms = ["tuple", "list", "array", "list", "tuple"]
    cases = []
    for form in forms:
        mean = planar_point(rng, 2.0, 4.0)
        sigma = float(rng.choice([rng.uniform(0.5, 0.8), rng.uniform(1.25, 1.6)]))  # never 1
        cases.append((mean, sigma, int(rng.integers(30_000, 60_000)), int(rng.integers(2**31)), form))
    got = yield [call("mean_shift", vector_form(m, form), s, n, seed) for m, s, n, seed, form in cases]
    return all_of([_shift_verdict(g, m, s, n, f"mean_shift({_show(m)}, {fmt(s)}, {n}, seed={seed})")
                   for g, (m, s, n, seed, form) in zip(got, cases)])


@CHECKS.check("mean_shift", points=1)
def mean_shift_reproducible(ctx):
    """mean_shift draws from np.random.default_rng(seed): the same seed gives the same number, another seed another"""
    rng = ctx.rng
    seed, other = (int(s) for s in rng.choice(2**31, size=2, replace=False))
    args = ((3, 4), 1.0, 2000)
    got = yield [call("mean_shift", *args, seed), call("mean_shift", *args, seed), call("mean_shift", *args, other)]
    label = "mean_shift((3, 4), 1, 2000, seed={})"
    return same_seed_same_value(got, label, seed, other)
