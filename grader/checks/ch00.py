"""Chapter 0: the range sensor r = sqrt(x^2 + y^2) is not linear, and noise shifts its mean.

mean_shift samples, so it is graded statistically: for R = |N(m, sigma^2 I)| with |m| = r the exact
mean and variance are known (R is Rice distributed), and the learner's sample mean over n draws
must lie within 5 standard errors, 5 sqrt(Var R / n), of E[R] - r. A correct function fails that
with probability below 1e-6; dropping the "- range(mean)", taking the range of the mean sample
or scaling the noise by sigma^2 moves the result by 6 or more standard errors at the inputs drawn
(r in [2, 3], sigma in [1.25, 1.6], n 6000..9000: no more samples than that takes, so a learner's
plain-Python loop stays quick).
Closed forms (range, superposition gap) are compared with rtol 1e-9.
"""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import call
from grader.checks.base import chapter_checks
from grader.checks.derivatives import planar_point, vector_form
from grader.checks.confusions import other_norms
from grader.checks.sampling import same_seed_same_value
from grader.judging.compare import (
    all_of,
    compare_arrays,
    exactly,
    expect,
    fail,
    fmt,
    value_problem,
)
from grader.judging.diagnose import Mistake
from grader.judging.expected import reference

CHECKS = chapter_checks("ch00")
CHECKS.uses("superposition_gap", "range_reading")
CHECKS.uses("mean_shift", "range_reading")

STANDARD_ERRORS = 5.0
REF = reference("ch00")


def _show(values) -> str:
    return "(" + ", ".join(fmt(v) for v in values) + ")"


@CHECKS.check("range_reading", points=1)
def range_reading_worked_example(ctx):
    """range_reading(3, 4) is 5"""
    got = yield call("range_reading", 3, 4)
    return expect(got, 5.0, label="range_reading(3, 4)", rtol=1e-12, mistakes=other_norms((3, 4), 5.0))


@CHECKS.check("range_reading", points=1)
def range_reading_random_points(ctx):
    """range_reading = sqrt(x^2 + y^2) at random points in all four quadrants, and at integers"""
    calls = [call("range_reading", float(x), float(y)) for x, y in (planar_point(ctx.rng) for _ in range(6))]
    calls.append(call("range_reading", -5, 12))
    expected = [REF.range_reading(*c.args) for c in calls]
    got = yield calls
    return all_of([expect(g, want, label=c.label, rtol=1e-9, mistakes=other_norms(c.args, want))
                   for g, want, c in zip(got, expected, calls)])


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
        gap = REF.superposition_gap(p, q)
        while gap > -0.1:  # p, q not nearly parallel
            q = planar_point(rng)
            gap = REF.superposition_gap(p, q)
        cases.append((p, q, form, gap))
    got = yield [call("superposition_gap", vector_form(p, form), vector_form(q, form)) for p, q, form, _ in cases]
    return all_of([expect(g, gap, label=f"superposition_gap({_show(p)}, {_show(q)}) with {form}s", rtol=1e-9, atol=1e-12)
                   for g, (p, q, form, gap) in zip(got, cases)])


def _shift_verdict(returned, law: tuple, n: int, label: str, variance_scale: float | None = None):
    """Within STANDARD_ERRORS standard errors of the exact mean shift E[R] - r (law: REF.shift_law); a wrong one
    named by the mean range, or by the shift of a cloud spread by sigma^2 (`variance_scale`, where known)."""
    problem = value_problem(returned, (), label)
    if problem:
        return fail(problem)
    shift, spread, approximation, r = law
    slips = [Mistake("mean range", "that is the mean range itself: subtract range(mean), the range of the mean "
                                   "position.", shift + r),
             Mistake("range of the mean sample", "that is the range of the samples' mean, which is about range(mean): "
                                                 "take the range of each sample first, then their mean.", 0.0)]
    if variance_scale is not None:
        slips.append(Mistake("variance as the scale", "the cloud spreads by sigma^2, not sigma: the samples are mean + "
                                                      "sigma * rng.standard_normal((n, 2)).", variance_scale))
    return compare_arrays(returned.as_array(), shift, label=f"{label} (about sigma^2/(2r) = {fmt(approximation)}; "
                          f"statistical, {STANDARD_ERRORS:g} standard errors)",
                          rtol=0.0, atol=float(STANDARD_ERRORS * spread / np.sqrt(n)), mistakes=slips) \
        .also(exactly(returned, shift))


@CHECKS.check("mean_shift", points=2)
def mean_shift_worked_example(ctx):
    """mean_shift((3, 4), sigma=1, n=100000) is about 0.10: the cloud's mean range moves outward"""
    law = REF.shift_law((3.0, 4.0), 1.0)
    got = yield call("mean_shift", (3, 4), 1.0, 100_000, 0)
    return _shift_verdict(got, law, 100_000, "mean_shift((3, 4), 1, 100000, seed=0)")


@CHECKS.check("mean_shift", points=2)
def mean_shift_random_inputs(ctx):
    """mean_shift matches the exact shift E[range] - range(mean) at random means, sigmas and seeds"""
    rng = ctx.rng
    forms = ["tuple", "list", "array", "list", "tuple"]
    cases = []
    for form in forms:
        mean = planar_point(rng, 2.0, 3.0)
        sigma = float(rng.uniform(1.25, 1.6))  # never 1, and a shift sigma^2/2r >= 0.26 that few samples show
        cases.append((mean, sigma, int(rng.integers(6_000, 9_000)), int(rng.integers(2**31)), form))
    laws = [REF.shift_law(m, s) for m, s, *_ in cases]
    squared = [REF.shift_law(m, s * s)[0] for m, s, *_ in cases]
    got = yield [call("mean_shift", vector_form(m, form), s, n, seed) for m, s, n, seed, form in cases]
    return all_of([_shift_verdict(g, law, n, f"mean_shift({_show(m)}, {fmt(s)}, {n}, seed={seed})", wide)
                   for g, law, wide, (m, s, n, seed, form) in zip(got, laws, squared, cases)])


@CHECKS.check("mean_shift", points=1)
def mean_shift_reproducible(ctx):
    """mean_shift draws from np.random.default_rng(seed): the same seed gives the same number, another seed another"""
    rng = ctx.rng
    seed, other = (int(s) for s in rng.choice(2**31, size=2, replace=False))
    args = ((3, 4), 1.0, 2000)
    got = yield [call("mean_shift", *args, seed), call("mean_shift", *args, seed), call("mean_shift", *args, other)]
    label = "mean_shift((3, 4), 1, 2000, seed={})"
    return same_seed_same_value(got, label, seed, other)
