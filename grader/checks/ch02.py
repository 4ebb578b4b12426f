"""Chapter 2: gradients, the tangent plane, and the gradient as the normal of a contour.

Closed forms are compared with rtol 1e-9; example_gradient also against central differences (see
grader/checks/derivatives.py for that tolerance). contour_direction is judged by what it must be:
a unit vector (| |t| - 1 | <= 1e-9) orthogonal to the gradient of the bowl g (|t . grad g| / |grad g|
<= 1e-9), either orientation. The points avoid the axes and the diagonals (g's principal axes), where
a radial or axis-aligned guess would happen to be right.
"""

from __future__ import annotations

import numpy as np

from grader.checks.base import chapter_checks
from grader.checks.derivatives import Derivative, add_derivative_checks, planar_point, vector_form
from grader.diagnose import Mistake
from grader.expected import reference
from grader.compare import Entries, all_of, compare_arrays, expect, expect_raises, fail, fmt_array, value_problem
from grader.wire import Fn, call

CHECKS = chapter_checks("ch02")
CHECKS.uses("contour_direction", "bowl_gradient")
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


@CHECKS.check("tangent_plane", points=1)
def tangent_plane_worked_example(ctx):
    """tangent_plane at a=(1, 2), x=(1.1, 2.1) for f with f(a) = 3 and grad f(a) = (4, 1), as x^2 + x y has: 3.50"""
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


@CHECKS.check("contour_direction", points=2)
def contour_direction_is_unit_and_perpendicular(ctx):
    """contour_direction is a unit vector with contour_direction . bowl_gradient = 0 (either orientation)"""
    calls = [call("contour_direction", float(x), float(y)) for x, y in _points(ctx.rng)]
    gradients = [REF.bowl_gradient(*c.args) for c in calls]
    got = yield calls
    verdicts = []
    for g, gradient, c in zip(got, gradients, calls):
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
                                       mistakes=[Mistake(normal.name, normal.help, [1.0, sign]) for sign in (1.0, -1.0)]))
    return all_of(verdicts)


@CHECKS.check("contour_direction", points=1)
def contour_direction_raises_at_origin(ctx):
    """contour_direction(0, 0) raises ValueError (the gradient vanishes, so there is no contour direction)"""
    got = yield call("contour_direction", 0.0, 0.0)
    return expect_raises(got, "ValueError", label="contour_direction(0, 0)", why="grad g = 0 at the origin")
