"""Chapter 6: the range-bearing measurement z = (r, bearing) and its Jacobian H."""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import Array, call
from grader.checks.base import chapter_checks
from grader.checks.confusions import other_norms
from grader.checks.derivatives import (
    INSIDE,
    Derivative,
    add_derivative_checks,
    add_exact_check,
    angle,
    elevation,
    integer_point,
    planar_point,
)
from grader.judging.compare import (
    Entries,
    Verdict,
    all_of,
    compare_arrays,
    expect,
    expect_raises,
    fmt,
    value_problem,
)
from grader.judging.diagnose import Mistake, known
from grader.judging.expected import reference

CHECKS = chapter_checks("ch06")
CHECKS.uses("measurement_covariance", "H_jacobian")
CHECKS.uses("H3_jacobian", "range_bearing_elevation")
REF = reference("ch06")

Z = Entries("z", rows=("range", "bearing"))
H = Entries("H", rows=("range", "bearing"), cols=("x", "y"), derivative=True)
R = Entries("R", rows=("range", "bearing"), cols=("range", "bearing"), product=True)


QUADRANTS = ((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0))


def _points(rng: np.random.Generator, n: int = 6) -> list:
    """n random points (planar_point), the k-th in quadrant k mod 4: four points or more meet every quadrant (atan
    and atan2 differ only where x < 0; grade selftest found seeds where eight random quadrants missed x < 0)."""
    return [np.abs(planar_point(rng)) * QUADRANTS[k % 4] for k in range(n)]


BEARING_SLIPS = {
    "atan": "the bearing is atan(y/x), which is off by pi in the left half-plane: use np.arctan2(y, x).",
    "reversed bearing": "the bearing is off by pi everywhere: it is measured from the dish to the drone, "
                        "atan2(y, x), not from the drone to the dish.",
    "degrees": "the bearing is in degrees: keep it in radians, as atan2 returns it.",
    "atan plus pi": "the bearing is atan(y/x) + pi: off by pi where x > 0 and by a whole turn where x and y are "
                    "both negative; np.arctan2(y, x) is right in every quadrant.",
}


def _bearing_slips(x: float, y: float) -> list[Mistake]:
    slips = known(REF.bearing_mistakes(x, y), BEARING_SLIPS)
    reversed_ = next(m for m in slips if m.name == "reversed bearing")
    # off by pi everywhere as a learner writes it, atan2(-y, -x) or atan2(y, x) +- pi: one mistake, either form
    return slips + [Mistake(reversed_.name, reversed_.help, reversed_.value + [0.0, turn]) for turn in (-2 * np.pi,
                                                                                                     2 * np.pi)] + \
        other_norms((x, y), REF.range_bearing(x, y), 0)


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
add_exact_check(CHECKS, "H_jacobian", H,
                lambda rng: [tuple(float(v) for v in planar_point(rng, *((0.01, 0.05) if k < 3 else (0.8, 4.5))))
                             for k in range(6)],
                REF.H_jacobian, "near the dish (r 0.01 to 0.05)")


@CHECKS.check("H_jacobian", points=1)
def H_rows_orthogonal(ctx):
    """H H^T from your H is the reference's: the range row is a unit vector, the bearing row orthogonal to it"""
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
    """H accepts integers and numpy scalars: H_jacobian(a, b) and H_jacobian(np.int64(a), b) at integers drawn for
    this run"""
    a, b = integer_point(ctx.rng)
    expected = REF.H_jacobian(a, b)
    got = yield [call("H_jacobian", a, b), call("H_jacobian", Array(a, "int64"), b)]
    return all_of([expect(g, expected, label=f"H_jacobian({a}, {b})", entries=H) for g in got])


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
    """measurement_covariance = H (sigma^2 I) H^T at random points and sigmas"""
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


# ------------------------------------------------------------------------------ range, bearing and elevation (3-D)

Z3 = Entries("z", rows=("range", "bearing", "elevation"))
H3 = Entries("H3", rows=("range", "bearing", "elevation"), cols=("x", "y", "z"), derivative=True)
GROUND_MIN = 0.1  # the contract: graded points have x^2 + y^2 >= 0.1

ELEVATION_SLIPS = {
    "colatitude": "the elevation is measured from the z-axis: it is the angle above the x-y plane, "
                  "atan2(z, sqrt(x^2 + y^2)).",
    "range without z": "the range leaves out z: it is the distance in 3-D.",
    "elevation over the 3-D range": "the elevation is atan2(z, r) with the 3-D range r: its tangent is z over the "
                                    "horizontal distance, atan2(z, sqrt(x^2 + y^2)) (or arcsin(z / r)).",
    "atan": "the bearing is atan(y/x), which is off by pi where x < 0: use np.arctan2(y, x).",
    "degrees": "the angles are in degrees: keep them in radians, as atan2 returns them.",
}
H3_SLIPS = {
    "elevation row sign": "d elevation/d x and d elevation/d y have the wrong sign: moving away from the z-axis "
                          "lowers the elevation of a point above the plane.",
    "bearing over r^2": "the bearing row is divided by the 3-D r^2: the bearing sees only the horizontal distance, "
                        "x^2 + y^2.",
    "elevation over rho^2": "the elevation row is divided by x^2 + y^2: the outer derivative of atan2(z, rho) "
                            "divides by rho^2 + z^2, the 3-D range squared.",
}


def _point_3d(rng: np.random.Generator, near: bool = False, octant: int | None = None) -> np.ndarray:
    """(x, y, z) with x^2 + y^2 in [0.12, 16] (near: [0.101, 0.13], beside the z-axis where the bearing is
    undefined), bearing and elevation away from the axes and diagonals, |elevation| <= 1.37; in octant `octant`
    mod 8 where given (the signs of x, y and z: the quadrants of _points, above and then below the plane)."""
    while True:
        rho = np.sqrt(rng.uniform(GROUND_MIN + INSIDE / 10, 0.13)) if near else np.sqrt(rng.uniform(0.12, 16.0))
        bearing, lift = angle(rng), elevation(rng)
        point = np.array([rho * np.cos(bearing), rho * np.sin(bearing), rho * np.tan(lift)])
        if octant is not None:
            point = np.abs(point) * np.array([*QUADRANTS[octant % 4], 1.0 if octant % 8 < 4 else -1.0])
        jacobian = REF.H3_jacobian(*point)
        if np.max(np.abs(jacobian - jacobian.T)) >= 0.01:
            return point


def _label3(function: str, point) -> str:
    return f"{function}({', '.join(fmt(v) for v in point)})"


@CHECKS.check("range_bearing_elevation", points=1)
def range_bearing_elevation_worked_example(ctx):
    """range_bearing_elevation(3, 4, 0) is (5, 0.9273, 0)"""
    want, slips = REF.range_bearing_elevation(3, 4, 0), REF.elevation_mistakes(3, 4, 0)
    got = yield call("range_bearing_elevation", 3, 4, 0)
    return expect(got, want, label="range_bearing_elevation(3, 4, 0)", entries=Z3, rtol=1e-9,
                  mistakes=known(slips, ELEVATION_SLIPS) + other_norms((3, 4, 0), want, 0))


@CHECKS.check("range_bearing_elevation", points=2)
def range_bearing_elevation_random_points(ctx):
    """range_bearing_elevation at random points in all eight octants (angles from atan2, in radians)"""
    rng = ctx.rng
    points = [_point_3d(rng, octant=k) for k in range(8)]
    expected = [REF.range_bearing_elevation(*p) for p in points]
    slips = [known(REF.elevation_mistakes(*p), ELEVATION_SLIPS) + other_norms(p, want, 0)
             for p, want in zip(points, expected)]
    got = yield [call("range_bearing_elevation", *(float(v) for v in p)) for p in points]
    return all_of([expect(g, want, label=_label3("range_bearing_elevation", p), entries=Z3, rtol=1e-9, atol=1e-12,
                          mistakes=s) for g, want, s, p in zip(got, expected, slips, points)])


@CHECKS.check("H3_jacobian", points=2)
def H3_worked_example(ctx):
    """H3_jacobian(1, 0, 1) is [[0.7071, 0, 0.7071], [0, 1, 0], [-0.5, 0, 0.5]]"""
    want, slips = REF.H3_jacobian(1, 0, 1), REF.H3_mistakes(1, 0, 1)
    got = yield call("H3_jacobian", 1, 0, 1)
    return expect(got, want, label="H3_jacobian(1, 0, 1)", entries=H3, rtol=1e-9, mistakes=known(slips, H3_SLIPS))


add_derivative_checks(CHECKS, Derivative(
    forward="range_bearing_elevation", jacobian="H3_jacobian", entries=H3,
    args=lambda p, extra: tuple(float(v) for v in p),
    reference_forward=lambda p, extra: REF.range_bearing_elevation(*p),
    reference_jacobian=lambda p, extra: REF.H3_jacobian(*p),
    cases=lambda rng: [(_point_3d(rng), ()) for _ in range(6)],
    mistakes=lambda p, extra: known(REF.H3_mistakes(*p), H3_SLIPS),
))
add_exact_check(CHECKS, "H3_jacobian", H3,
                lambda rng: [tuple(float(v) for v in _point_3d(rng, near=k < 3)) for k in range(6)],
                REF.H3_jacobian, "beside the z-axis (x^2 + y^2 from 0.1 to 0.13)")


@CHECKS.check("H3_jacobian", points=1)
def H3_rows_orthogonal(ctx):
    """the rows of your H3 are orthogonal: H3 H3^T is the diagonal matrix of their squared lengths"""
    points = [_point_3d(ctx.rng) for _ in range(5)]
    grams = [h @ h.T for h in (REF.H3_jacobian(*p) for p in points)]
    got = yield [call("H3_jacobian", *(float(v) for v in p)) for p in points]
    verdicts = []
    for g, gram, p in zip(got, grams, points):
        label = _label3("H3_jacobian", p)
        problem = value_problem(g, (3, 3), label)
        if problem:
            return Verdict(False, problem)
        h = g.as_array()
        verdicts.append(compare_arrays(h @ h.T, gram, label=f"H3 H3^T from your {label}", entries=Entries("H3 H3^T"),
                                       rtol=1e-6, atol=1e-9))
    return all_of(verdicts)


@CHECKS.check("H3_jacobian", points=1)
def H3_raises_on_the_z_axis(ctx):
    """H3_jacobian(0, 0, z) raises ValueError (no bearing where x = y = 0), also at the origin"""
    got = yield [call("H3_jacobian", 0.0, 0.0, z) for z in (1.3, -0.7, 0.0)]
    return all_of([expect_raises(g, "ValueError", label=f"H3_jacobian(0, 0, {fmt(z)})",
                                 why="the bearing is undefined where x = y = 0")
                   for g, z in zip(got, (1.3, -0.7, 0.0))])
