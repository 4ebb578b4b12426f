"""Chapter 3: the polar map p(r, theta) = (r cos theta, r sin theta), its Jacobian J and det J = r.

Closed forms are compared with rtol 1e-9 (atol 1e-12); J also against central differences (see
grader/checks/derivatives.py for that tolerance). Points have r in [0.5, 5] and angles at least
0.2 rad from every multiple of pi/4, so no entry of J is near 0 and J is never symmetric.
"""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import Array, call
from grader.checks.base import Skip, chapter_checks
from grader.checks.derivatives import (
    INSIDE,
    Derivative,
    add_derivative_checks,
    add_exact_check,
    angle,
    elevation,
    polar_point,
    wound,
)
from grader.judging.compare import (
    SINGLE_PRECISION,
    Entries,
    all_of,
    compare_arrays,
    expect,
    fail,
    fmt,
    value_problem,
)
from grader.judging.diagnose import Mistake, known
from grader.judging.expected import reference

CHECKS = chapter_checks("ch03")
CHECKS.uses("area_scale", "polar_to_cartesian_jacobian")
CHECKS.uses("volume_scale", "spherical_to_cartesian_jacobian")
REF = reference("ch03")

P = Entries("p", rows=("x", "y"))
J = Entries("J", rows=("x", "y"), cols=("r", "theta"), derivative=True)


def _points(rng: np.random.Generator, n: int = 6) -> list:
    return [polar_point(rng) for _ in range(n)]


def _label(function: str, *args: float) -> str:
    return f"{function}({', '.join(fmt(v) for v in args)})"


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
add_exact_check(CHECKS, "polar_to_cartesian_jacobian", J,
                lambda rng: [(float(rng.uniform(0.01, 0.05)), angle(rng)) for _ in range(3)] +
                            [(float(rng.uniform(0.5, 5.0)), wound(angle(rng), rng)) for _ in range(3)],
                REF.polar_to_cartesian_jacobian, "near r = 0 (r 0.01 to 0.05) and many turns round")


@CHECKS.check("area_scale", points=1)
def area_scale_worked_example(ctx):
    """area_scale(4, pi/3) is det J = 4"""
    got = yield call("area_scale", 4, np.pi / 3)
    return expect(got, 4.0, label="area_scale(4, pi/3)", rtol=1e-9)


@CHECKS.check("area_scale", points=1)
def area_scale_is_r(ctx):
    """area_scale is the signed determinant of J at random points (a negative r gives a negative determinant)"""
    rng = ctx.rng
    calls = [call("area_scale", float(r), float(t)) for r, t in _points(rng) + [(-rng.uniform(0.5, 3.0), angle(rng))]]
    expected = [REF.area_scale(*c.args) for c in calls]
    jacobians = [REF.polar_to_cartesian_jacobian(*c.args) for c in calls]
    got = yield calls
    return all_of([expect(g, want, label=c.label, rtol=1e-9, atol=1e-12, mistakes=[
        Mistake("unsigned determinant", "area_scale is the signed determinant of J: a negative r gives a negative "
                                        "value (no abs).", abs(want)),
        Mistake("determinant with a plus", "the determinant of [[a, b], [c, d]] is a d - b c: a minus between the "
                                           "two products.", J[0, 0] * J[1, 1] + J[0, 1] * J[1, 0])])
        for g, want, J, c in zip(got, expected, jacobians, calls)])


@CHECKS.check("area_scale", points=1)
def area_scale_is_det_of_your_jacobian(ctx):
    """area_scale equals the determinant of your own polar_to_cartesian_jacobian"""
    points = [(float(r), float(t)) for r, t in _points(ctx.rng, 4)]
    return (yield from _det_of_your_jacobian("area_scale", "polar_to_cartesian_jacobian", points,
                                             [REF.area_scale(*p) for p in points]))


def _det_of_your_jacobian(scale: str, jacobian: str, points: list[tuple], scales: list[float]):
    """The check that learner function `scale` is the determinant of the learner's own `jacobian` at `points`
    (the reference's determinants `scales` tell a wrong J, which is not judged here, from a wrong scale)."""
    got = yield [{"det": call(scale, *p), "J": call(jacobian, *p)} for p in points]
    n = len(points[0])
    verdicts = []
    for g, p, want in zip(got, points, scales):
        label = _label(scale, *p)
        problem = value_problem(g["det"], (), label)
        if problem:
            return fail(problem)
        own_label = _label(jacobian, *p)
        problem = value_problem(g["J"], (n, n), own_label)
        if problem:
            raise Skip(f"{problem} So {scale} cannot be compared with the determinant of your J: not judged, no "
                       "points lost.", costs_nothing=True)
        own_det = float(np.linalg.det(g["J"].as_array()))
        if not np.isclose(own_det, want, rtol=SINGLE_PRECISION, atol=1e-12):  # a float32 J is a right J
            raise Skip(f"the determinant of your {own_label} is {fmt(own_det)}, not {fmt(want)}: fix J first (see "
                       "its checks); not judged, no points lost.", costs_nothing=True)
        verdicts.append(compare_arrays(g["det"].as_array(), own_det, label=label, rtol=1e-9, atol=1e-12,
                                       expected_name="det of your J"))
    return all_of(verdicts)


# ------------------------------------------------------------------------------ spherical coordinates (3-D)

S = Entries("p", rows=("x", "y", "z"))
JS = Entries("J", rows=("x", "y", "z"), cols=("r", "azimuth", "elevation"), derivative=True)
ELEVATION_MAX = 1.4  # the contract: graded elevations stay within this of the horizon (cos(elevation) > 0.17)
R_MIN = 0.3  # the contract: graded ranges are at least this

SPHERICAL_SLIPS = {
    "colatitude": "the elevation is measured from the z-axis: it is the angle above the x-y plane, so z = r "
                  "sin(elevation) and the horizontal distance is r cos(elevation).",
    "degrees": "the angles are read as degrees: they are in radians.",
    "angles swapped": "azimuth and elevation are swapped: the arguments are (r, azimuth, elevation).",
}
SPHERICAL_JACOBIAN_SLIPS = {
    "missing r": "the azimuth and elevation columns miss the factor r: turning by an angle moves the point along "
                 "an arc whose length grows with r.",
    "missing cos(elevation)": "the azimuth column misses the factor cos(elevation): the azimuth turns the point "
                              "on a circle of radius r cos(elevation), not r.",
    "colatitude": "that is the Jacobian with the elevation measured from the z-axis: the elevation is the angle "
                  "above the x-y plane.",
}
VOLUME_SLIPS = {
    "r for r^2": "the determinant has one factor r: both angle columns of J carry r.",
    "missing cos(elevation)": "the determinant misses the factor the elevation brings: take the determinant of "
                              "the whole J.",
    "colatitude": "that is the determinant with the elevation measured from the z-axis: the elevation is the angle "
                  "above the x-y plane.",
}


def _spherical_point(rng: np.random.Generator, near: bool = False) -> np.ndarray:
    """(r, azimuth, elevation): r in [0.31, 5] and every angle away from the axes (near: r in [0.31, 0.5] and
    |elevation| in [1.2, 1.37], close to the poles where the Jacobian is singular); J never symmetric."""
    while True:
        r = rng.uniform(R_MIN + INSIDE, 0.5) if near else rng.uniform(R_MIN + INSIDE, 5.0)
        point = np.array([r, angle(rng), elevation(rng, 1.2 if near else 0.2)])
        jacobian = REF.spherical_to_cartesian_jacobian(*point)
        if np.max(np.abs(jacobian - jacobian.T)) >= 0.01:
            return point


@CHECKS.check("spherical_to_cartesian", points=1)
def spherical_worked_example(ctx):
    """spherical_to_cartesian(2, 0, 0) is (2, 0, 0)"""
    want = REF.spherical_to_cartesian(2, 0, 0)
    got = yield call("spherical_to_cartesian", 2, 0, 0)
    return expect(got, want, label="spherical_to_cartesian(2, 0, 0)", entries=S, rtol=1e-9)


@CHECKS.check("spherical_to_cartesian", points=2)
def spherical_random_points(ctx):
    """spherical_to_cartesian at random points above and below the horizon, in every direction (angles in radians)"""
    points = [_spherical_point(ctx.rng) for _ in range(6)]
    expected = [REF.spherical_to_cartesian(*p) for p in points]
    slips = [known(REF.spherical_mistakes(*p), SPHERICAL_SLIPS) for p in points]
    got = yield [call("spherical_to_cartesian", *(float(v) for v in p)) for p in points]
    return all_of([expect(g, want, label=_label("spherical_to_cartesian", *p), entries=S, rtol=1e-9,
                          atol=1e-12, mistakes=s) for g, want, s, p in zip(got, expected, slips, points)])


@CHECKS.check("spherical_to_cartesian_jacobian", points=2)
def spherical_jacobian_worked_example(ctx):
    """spherical_to_cartesian_jacobian(2, 0, 0) is diag(1, 2, 2)"""
    want, slips = REF.spherical_to_cartesian_jacobian(2, 0, 0), REF.spherical_jacobian_mistakes(2, 0, 0)
    got = yield call("spherical_to_cartesian_jacobian", 2, 0, 0)
    return expect(got, want, label="spherical_to_cartesian_jacobian(2, 0, 0)", entries=JS, rtol=1e-9,
                  mistakes=known(slips, SPHERICAL_JACOBIAN_SLIPS))


add_derivative_checks(CHECKS, Derivative(
    forward="spherical_to_cartesian", jacobian="spherical_to_cartesian_jacobian", entries=JS,
    args=lambda p, extra: tuple(float(v) for v in p),
    reference_forward=lambda p, extra: REF.spherical_to_cartesian(*p),
    reference_jacobian=lambda p, extra: REF.spherical_to_cartesian_jacobian(*p),
    cases=lambda rng: [(_spherical_point(rng), ()) for _ in range(6)],
    mistakes=lambda p, extra: known(REF.spherical_jacobian_mistakes(*p), SPHERICAL_JACOBIAN_SLIPS),
))
add_exact_check(CHECKS, "spherical_to_cartesian_jacobian", JS,
                lambda rng: [tuple(float(v) for v in _spherical_point(rng, near=True)) for _ in range(3)] +
                            [(float(r), wound(az, rng), float(el)) for r, az, el in
                             (_spherical_point(rng) for _ in range(3))],
                REF.spherical_to_cartesian_jacobian,
                "close to the poles (r 0.3 to 0.5, |elevation| 1.2 to 1.37) and at azimuths many turns round")


@CHECKS.check("volume_scale", points=1)
def volume_scale_worked_example(ctx):
    """volume_scale(2, 0, 0) is det J = 4"""
    want, slips = REF.volume_scale(2, 0, 0), REF.volume_scale_mistakes(2, 0, 0)
    got = yield call("volume_scale", 2, 0, 0)
    return expect(got, want, label="volume_scale(2, 0, 0)", rtol=1e-9, mistakes=known(slips, VOLUME_SLIPS))


@CHECKS.check("volume_scale", points=1)
def volume_scale_random_points(ctx):
    """volume_scale is the signed determinant of the spherical Jacobian at random points"""
    points = [_spherical_point(ctx.rng) for _ in range(6)]
    expected = [REF.volume_scale(*p) for p in points]
    slips = [known(REF.volume_scale_mistakes(*p), VOLUME_SLIPS) for p in points]
    got = yield [call("volume_scale", *(float(v) for v in p)) for p in points]
    return all_of([expect(g, want, label=_label("volume_scale", *p), rtol=1e-9, atol=1e-12, mistakes=s)
                   for g, want, s, p in zip(got, expected, slips, points)])


@CHECKS.check("volume_scale", points=1)
def volume_scale_is_det_of_your_jacobian(ctx):
    """volume_scale equals the determinant of your own spherical_to_cartesian_jacobian"""
    points = [tuple(float(v) for v in _spherical_point(ctx.rng)) for _ in range(4)]
    return (yield from _det_of_your_jacobian("volume_scale", "spherical_to_cartesian_jacobian", points,
                                             [REF.volume_scale(*p) for p in points]))
