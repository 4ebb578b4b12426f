"""Chapter 2: gradients, the tangent plane, and the gradient as the normal of a contour.

Closed forms are compared with rtol 1e-9; example_gradient also against central differences (see
grader/checks/derivatives.py for that tolerance). contour_direction is judged by what it must be:
a unit vector (| |t| - 1 | <= 1e-9) orthogonal to the gradient of the bowl g (|t . grad g| / |grad g|
<= 1e-9), either orientation. The points avoid the axes and the diagonals (g's principal axes), where
a radial or axis-aligned guess would happen to be right.
"""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import Fn, call
from grader.checks.base import chapter_checks
from grader.checks.derivatives import (
    INSIDE,
    Derivative,
    add_derivative_checks,
    add_exact_check,
    angle,
    planar_point,
    vector_form,
)
from grader.judging.compare import (
    Entries,
    all_of,
    compare_arrays,
    expect,
    expect_raises,
    fail,
    fmt,
    fmt_array,
    value_problem,
)
from grader.judging.diagnose import Evidence, Mistake, generated, known
from grader.judging.expected import reference

CHECKS = chapter_checks("ch02")
CHECKS.uses("contour_direction", "bowl_gradient")
CHECKS.uses("planner_cost_gradient", "planner_cost")
REF = reference("ch02")

GRAD_F = Entries("grad f", rows=("d f/d x", "d f/d y"), cols=("x", "y"))
GRAD_G = Entries("grad g", rows=("d g/d x", "d g/d y"), cols=("x", "y"))
CONTOUR = Entries("contour test", rows=("|t|", "t . grad g / |grad g|"))
UNIT_TOLERANCE = 1e-9

# (f, grad f) from the catalogue, each a function of one vector
PLANE_FUNCTIONS = (("wave_vec", "wave_grad_vec"), ("rosenbrock_vec", "rosenbrock_grad_vec"),
                   ("saddle3_vec", "saddle3_grad_vec"))


def _points(rng: np.random.Generator, n: int = 6) -> list:
    return [planar_point(rng) for _ in range(n)]


@CHECKS.check("example_f", points=1)
def example_f_worked_example(ctx):
    """example_f(1, 2) = 1 + 2 = 3"""
    got = yield call("example_f", 1, 2)
    return expect(got, 3.0, label="example_f(1, 2)", rtol=1e-12)


@CHECKS.check("example_f", points=1)
def example_f_random_points(ctx):
    """example_f = x^2 + x y at random points and at integers"""
    calls = [call("example_f", float(x), float(y)) for x, y in _points(ctx.rng)] + [call("example_f", -3, 5)]
    expected = [REF.example_f(*c.args) for c in calls]
    got = yield calls
    return all_of([expect(g, want, label=c.label, rtol=1e-9, atol=1e-12) for g, want, c in zip(got, expected, calls)])


@CHECKS.check("example_gradient", points=1)
def example_gradient_worked_example(ctx):
    """example_gradient(1, 2) is (4, 1)"""
    got = yield call("example_gradient", 1, 2)
    return expect(got, [4.0, 1.0], label="example_gradient(1, 2)", entries=GRAD_F, rtol=1e-12)


add_derivative_checks(CHECKS, Derivative(
    forward="example_f", jacobian="example_gradient", entries=GRAD_F,
    args=lambda p, extra: (float(p[0]), float(p[1])),
    reference_forward=lambda p, extra: REF.example_f(*p),
    reference_jacobian=lambda p, extra: REF.example_gradient(*p),
    cases=lambda rng: [(p, ()) for p in _points(rng)],
))


def _exact_points(rng: np.random.Generator) -> list[tuple[float, float]]:
    """Random points, half of them far out (|p| in [20, 60]), where rounding swamps a small-step difference."""
    return [tuple(float(v) for v in planar_point(rng, *((20.0, 60.0) if k % 2 else (0.8, 4.5)))) for k in range(6)]


add_exact_check(CHECKS, "example_gradient", GRAD_F, _exact_points, REF.example_gradient, "far from the origin")


@CHECKS.check("tangent_plane", points=1)
def tangent_plane_worked_example(ctx):
    """tangent_plane at the lesson's a=(1, 2), x=(1.1, 2.1) for f with f(a) = 3 and grad f(a) = (4, 1), as x^2 + x y has"""
    got = yield call("tangent_plane", Fn("plane_twin_vec"), Fn("plane_twin_grad_vec"), (1, 2), (1.1, 2.1))
    return expect(got, 3.5, label="tangent_plane(f, grad, a=(1, 2), x=(1.1, 2.1)) where f(1, 2) = 3 and "
                                  "grad(1, 2) = (4, 1)", rtol=1e-9)


@CHECKS.check("tangent_plane", points=2)
def tangent_plane_random_inputs(ctx):
    """tangent_plane = f(a) + grad f(a) . (x - a) for three functions (one of 3 variables), vectors as tuples, lists, arrays"""
    rng = ctx.rng
    forms = (("tuple", "tuple"), ("list", "array"), ("array", "list"), ("int array", "tuple"), ("list", "list"),
             ("array", "array"))
    cases = []
    for i, (form_a, form_x) in enumerate(forms):
        f, grad = PLANE_FUNCTIONS[i % len(PLANE_FUNCTIONS)]
        n = 3 if f == "saddle3_vec" else 2
        a = rng.integers(-3, 4, n).astype(float) if form_a == "int array" else rng.uniform(-2.5, 2.5, n)
        step = rng.choice([-1.0, 1.0], n) * rng.uniform(0.3, 1.2, n)
        cases.append((f, grad, a, a + step, form_a, form_x))
    expected = [REF.tangent_plane_of(f, grad, a, x) for f, grad, a, x, _, _ in cases]
    slips = [REF.tangent_plane_mistakes_of(f, grad, a, x) for f, grad, a, x, _, _ in cases]
    got = yield [call("tangent_plane", Fn(f), Fn(grad), vector_form(a, fa), vector_form(x, fx))
                 for f, grad, a, x, fa, fx in cases]
    return all_of([expect(g, want, rtol=1e-9, atol=1e-12,
                          label=f"tangent_plane({f}, {grad}, a={fmt_array(a)} as {fa}, x={fmt_array(x)} as {fx})",
                          mistakes=[Mistake("gradient at x", "the gradient is taken at x: the tangent plane uses "
                                                             "grad(a), the gradient at the point of tangency.",
                                            slip["gradient at x"])])
                   for g, want, slip, (f, grad, a, x, fa, fx) in zip(got, expected, slips, cases)])


@CHECKS.check("bowl_gradient", points=2)
def bowl_gradient_random_points(ctx):
    """bowl_gradient is the gradient of g = x^2 + 0.5xy + y^2 at random points and at integers"""
    calls = [call("bowl_gradient", float(x), float(y)) for x, y in _points(ctx.rng)] + [call("bowl_gradient", 3, -2)]
    expected = [REF.bowl_gradient(*c.args) for c in calls]
    got = yield calls
    return all_of([expect(g, want, label=c.label, entries=GRAD_G, rtol=1e-9, atol=1e-12)
                   for g, want, c in zip(got, expected, calls)])


add_exact_check(CHECKS, "bowl_gradient", GRAD_G, _exact_points, REF.bowl_gradient, "far from the origin")


@CHECKS.check("contour_direction", points=2)
def contour_direction_is_unit_and_perpendicular(ctx):
    """contour_direction is a unit vector with contour_direction . bowl_gradient = 0 (either orientation)"""
    calls = [call("contour_direction", float(x), float(y)) for x, y in _points(ctx.rng)]
    gradients = [REF.bowl_gradient(*c.args) for c in calls]
    directions = [REF.contour_direction(*c.args) for c in calls]
    got = yield calls
    verdicts = []
    for g, gradient, right, c in zip(got, gradients, directions, calls):
        problem = value_problem(g, (2,), c.label)
        if problem:
            return fail(problem)
        t = g.as_array()
        normal = Mistake("normal, not tangent", "that is the direction of the gradient, which is perpendicular to "
                                                "the contour: turn it by 90 degrees.", None)
        verdicts.append(compare_arrays(np.array([np.linalg.norm(t), t @ gradient / np.linalg.norm(gradient)]),
                                       np.array([1.0, 0.0]), label=f"{c.label} = {fmt_array(t)}; the gradient of g "
                                                                   f"there is {fmt_array(gradient)}",
                                       entries=CONTOUR, rtol=0.0, atol=UNIT_TOLERANCE,
                                       mistakes=[Mistake(normal.name, normal.help, [1.0, sign]) for sign in (1.0, -1.0)])
                        .also(lambda only, g=g, t=t, right=right: _either_orientation(t, right, generated(g, only))))
    return all_of(verdicts)


def _either_orientation(t: np.ndarray, right: np.ndarray, slips: list[Mistake]) -> Evidence:
    """The generated slips at one call against the learner's direction t, a direction and its opposite being the
    same answer (a slip that gives either right one says nothing)."""
    found = Evidence()
    for slip in slips:
        value = np.asarray(slip.value, dtype=float)
        if value.shape != t.shape or not np.all(np.isfinite(value)) or \
                any(np.allclose(value, sign * right, rtol=0.0, atol=UNIT_TOLERANCE) for sign in (1.0, -1.0)):
            continue
        if any(np.allclose(t, sign * value, rtol=1e-9, atol=1e-12) for sign in (1.0, -1.0)):
            found.matched[slip.id] = slip
        else:
            found.ruled_out.add(slip.id)
    return found


@CHECKS.check("contour_direction", points=1)
def contour_direction_raises_at_origin(ctx):
    """contour_direction(0, 0) raises ValueError (the gradient vanishes, so there is no contour direction)"""
    got = yield call("contour_direction", 0.0, 0.0)
    return expect_raises(got, "ValueError", label="contour_direction(0, 0)", why="grad g = 0 at the origin")


# ------------------------------------------------------------------------------ the planner's cost surface

COST = Entries("c")
GRAD_C = Entries("grad c", rows=("d c/d x", "d c/d y"), cols=("x", "y"))
OBSTACLE_MIN = 0.5  # the contract: graded points are at least this far from the obstacle
FORMS = ("tuple", "list", "array")

PLANNER_SLIPS = {
    "d^2 for d^4": "the obstacle term's derivative is divided by d^2: 1/d^2 is 1/u with u = d^2, and the chain "
                   "rule gives -1/u^2 times du/d(x, y), so the denominator is d^4.",
    "obstacle term sign": "the obstacle term's derivative has the wrong sign: 1/d^2 falls as the point moves away "
                          "from the obstacle (d/du of 1/u is negative).",
    "missing 2": "the obstacle term misses the inner derivative's factor 2: du/dx of u = (x - ox)^2 + (y - oy)^2 "
                 "is 2 (x - ox).",
    "missing lane term": "the lane term y^2 is missing from d c/d y.",
}
COST_SLIPS = {"1/d for 1/d^2": "the obstacle term is 1/d: the cost uses the squared distance, 1/d^2.",
              "missing lane term": "the lane term y^2 is missing."}


def _planner_case(rng: np.random.Generator, near: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(point, obstacle): the point at distance d in [0.5, 3] (near: [0.5, 0.6]) from the obstacle, d at least
    0.15 from 1 (where d^2 and d^4 agree), off the obstacle's axes, and every gradient entry at least 0.05."""
    while True:
        obstacle = rng.uniform(-3, 3, 2)
        d = rng.uniform(OBSTACLE_MIN + INSIDE, 0.6) if near else rng.uniform(OBSTACLE_MIN + INSIDE, 3.0)
        t = angle(rng)
        point = obstacle + d * np.array([np.cos(t), np.sin(t)])
        lane, push = 2 * point[1], 2 * d * np.array([np.cos(t), np.sin(t)]) / d**4
        if abs(d - 1) >= 0.15 and abs(point[1]) >= 0.1 and abs(push[0]) >= 0.05 and abs(lane - push[1]) >= 0.05:
            return point, obstacle


def _planner_cases(rng: np.random.Generator, n: int = 6) -> list[tuple[np.ndarray, np.ndarray, str]]:
    return [(*_planner_case(rng), form) for form in (FORMS * n)[:n]]


@CHECKS.check("planner_cost", points=1)
def planner_cost_worked_example(ctx):
    """planner_cost(0, 1, obstacle=(2, 1)) is 1.25"""
    want, slips = REF.planner_cost(0, 1, (2, 1)), REF.planner_cost_mistakes(0, 1, (2, 1))
    got = yield call("planner_cost", 0, 1, (2, 1))
    return expect(got, want, label="planner_cost(0, 1, (2, 1))", rtol=1e-9, mistakes=known(slips, COST_SLIPS))


@CHECKS.check("planner_cost", points=2)
def planner_cost_random_points(ctx):
    """planner_cost at random points and obstacles (at least 0.5 apart; the obstacle as a tuple, list or array, also of integers)"""
    cases = _planner_cases(ctx.rng) + [(np.array([1.0, -2.0]), np.array([3.0, 1.0]), "int array")]
    expected = [REF.planner_cost(*p, o) for p, o, _ in cases]
    slips = [known(REF.planner_cost_mistakes(*p, o), COST_SLIPS) for p, o, _ in cases]
    got = yield [call("planner_cost", float(p[0]), float(p[1]), vector_form(o, form)) for p, o, form in cases]
    return all_of([expect(g, want, rtol=1e-9, atol=1e-12, entries=COST, mistakes=s,
                          label=f"planner_cost({fmt(p[0])}, {fmt(p[1])}, {fmt_array(o)} as a {form})")
                   for g, want, s, (p, o, form) in zip(got, expected, slips, cases)])


@CHECKS.check("planner_cost", points=1)
def planner_cost_raises_at_the_obstacle(ctx):
    """planner_cost at the obstacle itself raises ValueError (the cost is undefined there)"""
    got = yield call("planner_cost", 1.5, -0.5, (1.5, -0.5))
    return expect_raises(got, "ValueError", label="planner_cost(1.5, -0.5, (1.5, -0.5))",
                         why="1/d^2 is undefined at d = 0")


@CHECKS.check("planner_cost_gradient", points=1)
def planner_cost_gradient_worked_example(ctx):
    """planner_cost_gradient(0, 1, obstacle=(2, 1)) is (0.25, 2)"""
    want, slips = REF.planner_cost_gradient(0, 1, (2, 1)), REF.planner_gradient_mistakes(0, 1, (2, 1))
    got = yield call("planner_cost_gradient", 0, 1, (2, 1))
    return expect(got, want, label="planner_cost_gradient(0, 1, (2, 1))", entries=GRAD_C, rtol=1e-9,
                  mistakes=known(slips, PLANNER_SLIPS))


PLANNER = Derivative(
    forward="planner_cost", jacobian="planner_cost_gradient", entries=GRAD_C,
    args=lambda p, extra: (float(p[0]), float(p[1]), vector_form(extra[0], extra[1])),
    reference_forward=lambda p, extra: REF.planner_cost(p[0], p[1], extra[0]),
    reference_jacobian=lambda p, extra: REF.planner_cost_gradient(p[0], p[1], extra[0]),
    cases=lambda rng: [(p, (o, form)) for p, o, form in _planner_cases(rng)],
    mistakes=lambda p, extra: known(REF.planner_gradient_mistakes(p[0], p[1], extra[0]), PLANNER_SLIPS),
)
add_derivative_checks(CHECKS, PLANNER)
add_exact_check(CHECKS, "planner_cost_gradient", GRAD_C,
                lambda rng: [(float(p[0]), float(p[1]), tuple(float(v) for v in o))
                             for p, o in [_planner_case(rng, near=k < 3) for k in range(6)]],
                REF.planner_cost_gradient, "within 0.6 of the obstacle")


@CHECKS.check("planner_cost_gradient", points=1)
def planner_cost_gradient_raises_at_the_obstacle(ctx):
    """planner_cost_gradient at the obstacle itself raises ValueError"""
    got = yield call("planner_cost_gradient", -2.0, 0.5, [-2.0, 0.5])
    return expect_raises(got, "ValueError", label="planner_cost_gradient(-2, 0.5, [-2, 0.5])",
                         why="the cost is undefined at the obstacle")
