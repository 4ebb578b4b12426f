"""Chapter 3: the polar map p(r, theta) = (r cos theta, r sin theta), its Jacobian J and det J = r.

Closed forms are compared with rtol 1e-9 (atol 1e-12); J also against central differences (see
grader/checks/derivatives.py for that tolerance). Points have r in [0.5, 5] and angles at least
0.2 rad from every multiple of pi/4, so no entry of J is near 0 and J is never symmetric.
"""

from __future__ import annotations

import numpy as np

from grader.checks.base import Skip, chapter_checks
from grader.checks.derivatives import Derivative, add_derivative_checks, angle, polar_point
from grader.compare import SINGLE_PRECISION, Entries, all_of, compare_arrays, expect, fail, fmt, value_problem
from grader.diagnose import Mistake
from grader.expected import reference
from grader.wire import Array, call

CHECKS = chapter_checks("ch03")
CHECKS.uses("area_scale", "polar_to_cartesian_jacobian")
REF = reference("ch03")

P = Entries("p", rows=("x", "y"))
J = Entries("J", rows=("x", "y"), cols=("r", "theta"), derivative=True)


def _points(rng: np.random.Generator, n: int = 6) -> list:
    return [polar_point(rng) for _ in range(n)]


def _label(function: str, r: float, theta: float) -> str:
    return f"{function}({fmt(r)}, {fmt(theta)})"


@CHECKS.check("polar_to_cartesian", points=1)
def polar_worked_example(ctx):
    """polar_to_cartesian(4, pi/3) is (2, 3.4641)"""
    want = REF.polar_to_cartesian(4, np.pi / 3)
    got = yield call("polar_to_cartesian", 4, np.pi / 3)
    return expect(got, want, label="polar_to_cartesian(4, pi/3)", entries=P, rtol=1e-9)


@CHECKS.check("polar_to_cartesian", points=1)
def polar_random_points(ctx):
    """polar_to_cartesian = (r cos theta, r sin theta) at random points in all four quadrants (theta in radians)"""
    calls = [call("polar_to_cartesian", float(r), float(t)) for r, t in _points(ctx.rng)]
    expected = [REF.polar_to_cartesian(*c.args) for c in calls] + [REF.polar_to_cartesian(3, 2)]
    in_degrees = [REF.polar_in_degrees(*c.args) for c in calls] + [REF.polar_in_degrees(3, 2)]
    calls.append(call("polar_to_cartesian", Array(3, "int64"), 2))
    got = yield calls
    return all_of([expect(g, want, label=c.label, entries=P, rtol=1e-9, atol=1e-12, mistakes=[
        Mistake("degrees", "theta is read as degrees: it is in radians, use np.cos(theta) and np.sin(theta) as "
                           "they are.", degrees)])
        for g, want, degrees, c in zip(got, expected, in_degrees, calls)])


@CHECKS.check("polar_to_cartesian_jacobian", points=2)
def jacobian_worked_example(ctx):
    """J at (4, pi/3) is [[0.5, -3.4641], [0.8660, 2.0]]"""
    want = REF.polar_to_cartesian_jacobian(4, np.pi / 3)
    got = yield call("polar_to_cartesian_jacobian", 4, np.pi / 3)
    return expect(got, want, label="polar_to_cartesian_jacobian(4, pi/3)", entries=J, rtol=1e-9)


add_derivative_checks(CHECKS, Derivative(
    forward="polar_to_cartesian", jacobian="polar_to_cartesian_jacobian", entries=J,
    args=lambda p, extra: (float(p[0]), float(p[1])),
    reference_forward=lambda p, extra: REF.polar_to_cartesian(*p),
    reference_jacobian=lambda p, extra: REF.polar_to_cartesian_jacobian(*p),
    cases=lambda rng: [(p, ()) for p in _points(rng)],
))


@CHECKS.check("area_scale", points=1)
def area_scale_worked_example(ctx):
    """area_scale(4, pi/3) is det J = 4"""
    got = yield call("area_scale", 4, np.pi / 3)
    return expect(got, 4.0, label="area_scale(4, pi/3)", rtol=1e-9)


@CHECKS.check("area_scale", points=1)
def area_scale_is_r(ctx):
    """area_scale = det J = r at random points (signed: a negative r gives a negative det)"""
    rng = ctx.rng
    calls = [call("area_scale", float(r), float(t)) for r, t in _points(rng) + [(-rng.uniform(0.5, 3.0), angle(rng))]]
    expected = [REF.area_scale(*c.args) for c in calls]
    got = yield calls
    return all_of([expect(g, want, label=c.label, rtol=1e-9, atol=1e-12, mistakes=[
        Mistake("unsigned determinant", "area_scale is the signed determinant of J: a negative r gives a negative "
                                        "value (no abs).", abs(want))])
        for g, want, c in zip(got, expected, calls)])


@CHECKS.check("area_scale", points=1)
def area_scale_is_det_of_your_jacobian(ctx):
    """area_scale equals the determinant of your own polar_to_cartesian_jacobian"""
    points = _points(ctx.rng, 4)
    scales = [REF.area_scale(float(r), float(t)) for r, t in points]
    got = yield [{"det": call("area_scale", float(r), float(t)), "J": call("polar_to_cartesian_jacobian", float(r), float(t))}
                 for r, t in points]
    verdicts = []
    for g, (r, t), scale in zip(got, points, scales):
        label = _label("area_scale", r, t)
        problem = value_problem(g["det"], (), label)
        if problem:
            return fail(problem)
        problem = value_problem(g["J"], (2, 2), _label("polar_to_cartesian_jacobian", r, t))
        if problem:
            raise Skip(f"{problem} So area_scale cannot be compared with the determinant of your J: not judged, no "
                       "points lost.", costs_nothing=True)
        own_det = float(np.linalg.det(g["J"].as_array()))
        if not np.isclose(own_det, scale, rtol=SINGLE_PRECISION, atol=1e-12):  # a float32 J is a right J
            raise Skip(f"the determinant of your {_label('polar_to_cartesian_jacobian', r, t)} is {fmt(own_det)}, "
                       f"not {fmt(scale)}: fix J first (see its checks); not judged, no points lost.",
                       costs_nothing=True)
        verdicts.append(compare_arrays(g["det"].as_array(), own_det, label=label, rtol=1e-9, atol=1e-12,
                                       expected_name="det of your J"))
    return all_of(verdicts)
