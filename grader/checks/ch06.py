"""Chapter 6: the range-bearing measurement z = (r, bearing) and its Jacobian H."""

from __future__ import annotations

import numpy as np

from grader.checks.base import chapter_checks
from grader.checks.derivatives import Derivative, add_derivative_checks, planar_point
from grader.compare import Entries, Verdict, all_of, compare_arrays, expect, expect_raises, value_problem
from grader.diagnose import Mistake
from grader.expected import reference
from grader.wire import Array, call

CHECKS = chapter_checks("ch06")
CHECKS.uses("measurement_covariance", "H_jacobian")
REF = reference("ch06")

Z = Entries("z", rows=("range", "bearing"))
H = Entries("H", rows=("range", "bearing"), cols=("x", "y"), derivative=True)
R = Entries("R", rows=("range", "bearing"), cols=("range", "bearing"))


def _points(rng: np.random.Generator, n: int = 6) -> list:
    return [planar_point(rng) for _ in range(n)]


BEARING_SLIPS = {
    "atan": "the bearing is atan(y/x), which is off by pi in the left half-plane: use np.arctan2(y, x).",
    "reversed bearing": "the bearing is off by pi everywhere: it is measured from the dish to the drone, "
                        "atan2(y, x), not from the drone to the dish.",
    "degrees": "the bearing is in degrees: keep it in radians, as atan2 returns it.",
}


def _bearing_slips(x: float, y: float) -> list[Mistake]:
    values = REF.bearing_mistakes(x, y)
    return [Mistake(name, help, values[name]) for name, help in BEARING_SLIPS.items()]


def _H_slips(x: float, y: float, H: np.ndarray) -> list[Mistake]:
    """H with the bearing row over r instead of r^2 (arithmetic on the right H)."""
    over_r = np.array(H, dtype=float)
    over_r[1] = over_r[1] * float(np.hypot(x, y))
    return [Mistake("bearing over r", "the bearing row is divided by r: d bearing/d(x, y) = (-y, x) / r^2.", over_r)]


def _sigma_slip(R: np.ndarray, sigma: float) -> list[Mistake]:
    return [Mistake("sigma not squared", "sigma multiplies the result once: the position covariance is sigma^2 I.",
                    np.asarray(R, dtype=float) / sigma)]


@CHECKS.check("range_bearing", points=1)
def range_bearing_worked_example(ctx):
    """range_bearing at the lesson's point (3, 4) gives (5, 0.9273)"""
    want, slips = REF.range_bearing(3, 4), _bearing_slips(3, 4)
    got = yield call("range_bearing", 3, 4)
    return expect(got, want, label="range_bearing(3, 4)", entries=Z, rtol=1e-9, mistakes=slips)


@CHECKS.check("range_bearing", points=2)
def range_bearing_all_quadrants(ctx):
    """range_bearing at random points in all four quadrants (bearing is atan2, in [-pi, pi])"""
    calls = [call("range_bearing", float(x), float(y)) for x, y in _points(ctx.rng, 8)]
    expected = [REF.range_bearing(*c.args) for c in calls]
    slips = [_bearing_slips(*c.args) for c in calls]
    got = yield calls
    return all_of([expect(g, want, label=c.label, entries=Z, rtol=1e-9, mistakes=s)
                   for g, want, s, c in zip(got, expected, slips, calls)])


@CHECKS.check("H_jacobian", points=2)
def H_worked_example(ctx):
    """H at the lesson's point (3, 4) is [[0.6, 0.8], [-0.16, 0.12]]"""
    want = REF.H_jacobian(3, 4)
    got = yield call("H_jacobian", 3, 4)
    return expect(got, want, label="H_jacobian(3, 4)", entries=H, rtol=1e-9, mistakes=_H_slips(3, 4, want))


add_derivative_checks(CHECKS, Derivative(
    forward="range_bearing", jacobian="H_jacobian", entries=H,
    args=lambda p, extra: (float(p[0]), float(p[1])),
    reference_forward=lambda p, extra: REF.range_bearing(p[0], p[1]),
    reference_jacobian=lambda p, extra: REF.H_jacobian(p[0], p[1]),
    cases=lambda rng: [(p, ()) for p in _points(rng)],
    mistakes=lambda p, extra: _H_slips(p[0], p[1], REF.H_jacobian(p[0], p[1])),
))


@CHECKS.check("H_jacobian", points=1)
def H_rows_orthogonal(ctx):
    """H H^T = diag(1, 1/r^2): the range row is a unit vector, the bearing row is orthogonal to it"""
    calls = [call("H_jacobian", float(x), float(y)) for x, y in _points(ctx.rng, 5)]
    grams = [REF.measurement_covariance(*c.args, 1.0) for c in calls]  # H H^T = H (1^2 I) H^T
    got = yield calls
    verdicts = []
    for g, gram, c in zip(got, grams, calls):
        problem = value_problem(g, (2, 2), c.label)
        if problem:
            return Verdict(False, problem)
        h = g.as_array()
        verdicts.append(compare_arrays(h @ h.T, gram, label=f"H H^T from your {c.label}",
                                       entries=Entries("H H^T"), rtol=1e-6, atol=1e-9))
    return all_of(verdicts)


@CHECKS.check("H_jacobian", points=1)
def H_integer_and_array_inputs(ctx):
    """H accepts integers and numpy scalars: H_jacobian(-4, 3) and H_jacobian(np.int64(-4), 3)"""
    expected = REF.H_jacobian(-4, 3)
    got = yield [call("H_jacobian", -4, 3), call("H_jacobian", Array(-4, "int64"), 3)]
    return all_of([expect(g, expected, label="H_jacobian(-4, 3)", entries=H) for g in got])


@CHECKS.check("H_jacobian", points=1)
def H_raises_at_origin(ctx):
    """H_jacobian(0, 0) raises ValueError (the bearing is undefined at r = 0)"""
    got = yield call("H_jacobian", 0.0, 0.0)
    return expect_raises(got, "ValueError", label="H_jacobian(0, 0)", why="H is undefined at r = 0")


@CHECKS.check("measurement_covariance", points=1)
def covariance_worked_example(ctx):
    """measurement_covariance(3, 4, sigma=1) is diag(1, 0.04)"""
    want = REF.measurement_covariance(3, 4, 1.0)
    got = yield call("measurement_covariance", 3, 4, 1.0)
    return expect(got, want, label="measurement_covariance(3, 4, 1)", entries=R)  # sigma = 1: sigma^2 cannot show


@CHECKS.check("measurement_covariance", points=2)
def covariance_random_points(ctx):
    """measurement_covariance = H (sigma^2 I) H^T = sigma^2 diag(1, 1/r^2) at random points and sigmas"""
    rng = ctx.rng
    calls = [call("measurement_covariance", float(x), float(y), float(rng.uniform(0.1, 2.0))) for x, y in _points(rng, 6)]
    expected = [REF.measurement_covariance(*c.args) for c in calls]
    got = yield calls
    return all_of([expect(g, want, label=c.label, entries=R, mistakes=_sigma_slip(want, c.args[2]))
                   for g, want, c in zip(got, expected, calls)])


@CHECKS.check("measurement_covariance", points=1)
def covariance_raises_at_origin(ctx):
    """measurement_covariance(0, 0, 1) raises ValueError"""
    got = yield call("measurement_covariance", 0.0, 0.0, 1.0)
    return expect_raises(got, "ValueError", label="measurement_covariance(0, 0, 1)")
