"""Chapter 5: finite differences, the numerical Jacobian and "the Jacobian check".

The scalar functions f are catalogue callables with known derivatives, so every difference
quotient is judged against the exact derivative f'(x) with a tolerance derived from h:

- central: (f(x+h) - f(x-h)) / 2h - f'(x) = h^2/12 (f'''(a) + f'''(b)) for some a, b in
  [x-h, x+h], so |error| <= h^2/6 M3 (M3 = max |f'''| on [x-h, x+h], taken on a fine grid, +5%);
- forward: (f(x+h) - f(x)) / h - f'(x) = h/2 f''(c) for some c in [x, x+h], so the error lies in
  h/2 [min f'', max f''] on [x, x+h] (+-2% of its width and size): two-sided, so a central
  difference (error ~ h^2) fails it as surely as a backward one (error -h/2 f'');
- rounding, for both: each f value is within eps |f| (sizes of the terms for the cubic), each
  argument x +- h within eps/2 (|x| + h), so it adds at most 2 eps (M0 + (|x| + h) M1) / h.
The steps are 1e-2..1e-1 and the points keep |f''| large, so a forward or backward difference
misses the central tolerance, and a central one the forward interval, by a factor 20 or more.
The lesson's property: over h = 0.1, 0.05, 0.025, 0.0125 the log-log slope of the error is 2 for
central and 1 for forward differences (1.9997..2.0003 and 0.98..1.02 at the points drawn; accepted
within +-0.15).

jacobian_fd is compared with the analytic Jacobian of catalogue vector functions (one R^3 -> R^2,
so m != n shows a transposed result by its shape); with h <= 1e-4 its error is below 1e-8, well
inside the finite-difference tolerance 1e-6 + 1e-6 |J| of grader/checks/derivatives.py.
max_jacobian_error must be about 0 (<= 1e-6) for right Jacobians and max |J_wrong - J| (to 2e-6)
for deliberately wrong ones, one of them wrong with a negative sign so that a missing abs shows.
best_step is graded as the contract says: the central-difference error at the returned h, computed
here with the same catalogue function, must be within 10x of the smallest error over hs (which is
floored at eps max(1, |f'(x)|), in case one step happens to hit the exact value).
"""

from __future__ import annotations

import numpy as np

from grader.catalogue import CALLABLES
from grader.checks.base import chapter_checks
from grader.checks.derivatives import FD_ATOL, FD_RTOL, angle, planar_point, polar_point, vector_form
from grader.compare import Entries, all_of, expect, fail, fmt, fmt_array, passed, value_problem
from grader.wire import Array, Fn, call

CHECKS = chapter_checks("ch05")

EPS = float(np.finfo(float).eps)
SLOPE_STEPS = (0.1, 0.05, 0.025, 0.0125)
SLOPE_TOLERANCE = 0.15
BEST_STEP_FACTOR = 10.0
GRID = 201


def _c(value):
    return lambda x: np.full_like(np.asarray(x, dtype=float), value)


# name -> (catalogue f, catalogue f', [f, f', f'', f'''] as numpy functions, size of f's terms)
SCALAR = {
    "sin": ("sin", "cos", [np.sin, np.cos, lambda x: -np.sin(x), lambda x: -np.cos(x)], lambda x: 1.0 + 0 * x),
    "exp": ("exp", "exp", [np.exp] * 4, np.exp),
    "cubic": ("cubic", "cubic_prime", [lambda x: x**3 - 2 * x, lambda x: 3 * x**2 - 2, lambda x: 6 * x, _c(6.0)],
              lambda x: np.abs(x) ** 3 + 2 * np.abs(x)),
    "sqrt": ("sqrt", "sqrt_prime", [np.sqrt, lambda x: 0.5 * x**-0.5, lambda x: -0.25 * x**-1.5,
                                    lambda x: 0.375 * x**-2.5], np.sqrt),
    "log": ("log", "reciprocal", [np.log, lambda x: 1 / x, lambda x: -1 / x**2, lambda x: 2 / x**3],
            lambda x: np.abs(np.log(x)) + 1.0),
}


def _derivative(name: str, order: int, x):
    return SCALAR[name][2][order](np.asarray(x, dtype=float))


def _point(rng: np.random.Generator, name: str, third: bool = False) -> float:
    """A point where f'' (or, with third=True, f''') stays well away from 0 within 0.1 of it."""
    sign = float(rng.choice([-1.0, 1.0]))
    if name == "sin":  # |sin| >= 0.64 (f'') or |cos| >= 0.62 (f''') on [x - 0.1, x + 0.1]
        ranges = ((0.2, 0.8), (2.35, 2.9)) if third else ((0.8, 1.3), (1.85, 2.35))
        return sign * float(rng.uniform(*ranges[rng.integers(2)]))
    if name == "cubic":
        return sign * float(rng.uniform(1.2, 2.0))
    if name == "exp":
        return float(rng.uniform(-1.0, 1.0))
    return float(rng.uniform(2.0, 6.0))  # sqrt, log


def _step(rng: np.random.Generator) -> float:
    """A moderately large step in [0.01, 0.1], so that truncation errors are visible."""
    return float(10 ** rng.uniform(-2.0, -1.0))


def _grid(a: float, b: float) -> np.ndarray:
    return np.linspace(a, b, GRID)


def _rounding(name: str, x: float, h: float, a: float, b: float) -> float:
    xs = _grid(a, b)
    m0 = float(np.max(SCALAR[name][3](xs)))
    m1 = float(np.max(np.abs(_derivative(name, 1, xs))))
    return 2 * EPS * (m0 + (abs(x) + h) * m1) / h + 4 * EPS * abs(float(_derivative(name, 1, x)))


def central_bounds(name: str, x: float, h: float) -> tuple[float, float]:
    """The interval the central-difference error (result - f'(x)) must lie in."""
    m3 = float(np.max(np.abs(_derivative(name, 3, _grid(x - h, x + h)))))
    half = 1.05 * h * h / 6 * m3 + _rounding(name, x, h, x - h, x + h)
    return -half, half


def forward_bounds(name: str, x: float, h: float) -> tuple[float, float]:
    """The interval the forward-difference error (result - f'(x)) must lie in: h/2 f''(c), c in [x, x+h]."""
    second = _derivative(name, 2, _grid(x, x + h))
    low, high = h / 2 * float(second.min()), h / 2 * float(second.max())
    slack = 0.02 * (high - low) + 0.02 * h / 2 * float(np.abs(second).max()) + _rounding(name, x, h, x, x + h)
    return low - slack, high + slack


def _difference_verdict(returned, name: str, x, h: float, function: str, bounds, what: str):
    label = f"{function}({name}, {fmt(x)}, {fmt(h)})"
    problem = value_problem(returned, (), label)
    if problem:
        return fail(problem)
    exact = float(_derivative(name, 1, x))
    got = float(returned.as_array())
    low, high = bounds(name, float(x), h)
    error = got - exact
    if low <= error <= high:
        return passed(expected=exact, got=got)
    forward = float((SCALAR[name][2][0](x + h) - SCALAR[name][2][0](x)) / h)
    central = float((SCALAR[name][2][0](x + h) - SCALAR[name][2][0](x - h)) / (2 * h))
    hint = ""
    if function == "central_difference" and abs(got - forward) <= 1e-9 * max(1.0, abs(forward)):
        hint = " That is the forward difference (f(x+h) - f(x))/h; the central one uses f(x+h) - f(x-h) over 2h."
    elif function == "forward_difference" and abs(got - central) <= 1e-9 * max(1.0, abs(central)):
        hint = " That is the central difference; the forward one is (f(x+h) - f(x))/h."
    return fail(f"{label}: got {fmt(got)}; the exact derivative is {fmt(exact)}, so the error is {error:.3g}, "
                f"but {what} must be in [{low:.3g}, {high:.3g}].{hint}", expected=exact, got=got)


def _scalar_cases(rng: np.random.Generator) -> list:
    """(function name, x as passed, h): every catalogue function, one with an integer x."""
    cases = [(name, _point(rng, name), _step(rng)) for name in ("sin", "exp", "cubic", "sqrt", "log", "sin")]
    cases.append(("cubic", int(rng.choice([-2, 2])), _step(rng)))
    return cases


def _slope_check(function: str, order: int, ctx):
    rng = ctx.rng
    cases = [(name, _point(rng, name, third=order == 2)) for name in ("sin", "exp", "cubic")]
    got = yield [[call(function, Fn(SCALAR[name][0]), x, h) for h in SLOPE_STEPS] for name, x in cases]
    steps = np.array(SLOPE_STEPS)
    for values, (name, x) in zip(got, cases):
        label = f"{function}({name}, {fmt(x)}, h)"
        for g, h in zip(values, steps):
            problem = value_problem(g, (), f"{function}({name}, {fmt(x)}, {fmt(h)})")
            if problem:
                return fail(problem)
        errors = np.abs(np.array([float(g.as_array()) for g in values]) - float(_derivative(name, 1, x)))
        if not np.all(np.isfinite(errors)) or np.any(errors <= 0):
            return fail(f"{label} for h = {', '.join(fmt(h) for h in steps)} has errors {fmt_array(errors)}: "
                        "they must be positive to fit a log-log slope.", got=errors)
        slope = float(np.polyfit(np.log(steps), np.log(errors), 1)[0])
        if abs(slope - order) > SLOPE_TOLERANCE:
            return fail(f"{label}: for h = {', '.join(fmt(h) for h in steps)} the errors |result - f'(x)| are "
                        f"{fmt_array(errors)}, a log-log slope of {slope:.3f}; a {function.split('_')[0]} difference's "
                        f"error shrinks like h^{order} (slope {order} +- {SLOPE_TOLERANCE:g}).",
                        expected=float(order), got=slope)
    return passed()


# ------------------------------------------------------------------------------ forward_difference

@CHECKS.check("forward_difference", points=1)
def forward_difference_worked_example(ctx):
    """forward_difference(sin, 1, 1e-3) = (sin 1.001 - sin 1)/0.001 = 0.539881 (cos 1 = 0.540302)"""
    got = yield call("forward_difference", Fn("sin"), 1.0, 1e-3)
    return expect(got, (np.sin(1.001) - np.sin(1.0)) / 1e-3, label="forward_difference(sin, 1, 0.001)",
                  rtol=1e-8)


@CHECKS.check("forward_difference", points=1)
def forward_difference_random_inputs(ctx):
    """forward_difference misses f'(x) by h/2 f''(c), c in [x, x+h]: sin, exp, a cubic, sqrt, log at random x, h = 0.01..0.1"""
    cases = _scalar_cases(ctx.rng)
    got = yield [call("forward_difference", Fn(SCALAR[name][0]), x, h) for name, x, h in cases]
    return all_of([_difference_verdict(g, name, x, h, "forward_difference", forward_bounds,
                                       "a forward difference's error h/2 f''(c)")
                   for g, (name, x, h) in zip(got, cases)])


@CHECKS.check("forward_difference", points=1)
def forward_difference_error_is_order_h(ctx):
    """halving h halves the forward-difference error: log-log slope 1 over h = 0.1 .. 0.0125"""
    return (yield from _slope_check("forward_difference", 1, ctx))


# ------------------------------------------------------------------------------ central_difference

@CHECKS.check("central_difference", points=1)
def central_difference_worked_example(ctx):
    """central_difference(sin, 1, 1e-5) is cos(1) = 0.5403023 to about 1e-10"""
    got = yield call("central_difference", Fn("sin"), 1.0, 1e-5)
    return expect(got, np.cos(1.0), label="central_difference(sin, 1, 1e-05)", rtol=0.0, atol=1e-10)


@CHECKS.check("central_difference", points=2)
def central_difference_random_inputs(ctx):
    """central_difference is within h^2/6 max|f'''| of f'(x): sin, exp, a cubic, sqrt, log at random x, h = 0.01..0.1"""
    cases = _scalar_cases(ctx.rng)
    got = yield [call("central_difference", Fn(SCALAR[name][0]), x, h) for name, x, h in cases]
    return all_of([_difference_verdict(g, name, x, h, "central_difference", central_bounds,
                                       "a central difference's error h^2/6 f'''")
                   for g, (name, x, h) in zip(got, cases)])


@CHECKS.check("central_difference", points=1)
def central_difference_error_is_order_h_squared(ctx):
    """halving h quarters the central-difference error: log-log slope 2 over h = 0.1 .. 0.0125"""
    return (yield from _slope_check("central_difference", 2, ctx))


# ------------------------------------------------------------------------------ jacobian_fd

# catalogue vector function -> (its analytic Jacobian, entry names)
VECTOR = {
    "polar_vec": ("polar_jac", Entries("J", rows=("x", "y"), cols=("r", "theta"), derivative=True)),
    "g_stage_vec": ("g_jac", Entries("J", rows=("u1^2 + u2", "u1 u2"), cols=("u1", "u2"), derivative=True)),
    "range_bearing_vec": ("range_bearing_jac", Entries("J", rows=("range", "bearing"), cols=("x", "y"),
                                                       derivative=True)),
    "two_of_three_vec": ("two_of_three_jac", Entries("J", rows=("x y + sin z", "x^2 z - y"), cols=("x", "y", "z"),
                                                     derivative=True)),
}


def _vector_point(rng: np.random.Generator, name: str) -> np.ndarray:
    if name == "polar_vec":
        return polar_point(rng)
    if name == "range_bearing_vec":
        return planar_point(rng)
    if name == "g_stage_vec":  # |u1|, |u2| >= 0.5: no zero entry in Jg
        return rng.choice([-1.0, 1.0], 2) * rng.uniform(0.5, 3.0, 2)
    return np.array([*(rng.choice([-1.0, 1.0], 2) * rng.uniform(0.5, 2.5, 2)), angle(rng)])  # two_of_three


def _analytic(name: str, point) -> np.ndarray:
    return np.asarray(CALLABLES[VECTOR[name][0]](np.asarray(point, dtype=float)), dtype=float)


def _show(point) -> str:
    return "(" + ", ".join(fmt(v) for v in np.asarray(point, dtype=float)) + ")"


@CHECKS.check("jacobian_fd", points=2)
def jacobian_fd_worked_example(ctx):
    """jacobian_fd of the polar map at (4, pi/3) is [[0.5, -3.4641], [0.8660, 2.0]] to 1e-6"""
    got = yield call("jacobian_fd", Fn("polar_vec"), (4, np.pi / 3))
    return expect(got, _analytic("polar_vec", (4, np.pi / 3)), label="jacobian_fd(polar, (4, pi/3))",
                  rtol=0.0, atol=1e-6, entries=VECTOR["polar_vec"][1])


@CHECKS.check("jacobian_fd", points=2)
def jacobian_fd_random_inputs(ctx):
    """jacobian_fd matches the analytic Jacobian (m x n, also 2 x 3) of four maps at random points, given h or not"""
    rng = ctx.rng
    plan = [("polar_vec", "tuple", None), ("g_stage_vec", "list", None), ("range_bearing_vec", "array", None),
            ("two_of_three_vec", "list", None), ("two_of_three_vec", "array", 1e-4),
            ("range_bearing_vec", "tuple", "h=1e-6"), ("polar_vec", "array", 1e-4)]
    cases = [(name, _vector_point(rng, name), form, h) for name, form, h in plan]
    cases += [("g_stage_vec", np.array([2.0, -3.0]), "int array", None),
              ("two_of_three_vec", np.array([1.0, -2.0, 2.0]), "int array", None)]
    calls = []
    for name, point, form, h in cases:
        args = (Fn(name), vector_form(point, form))
        if h is None:
            calls.append(call("jacobian_fd", *args))
        elif isinstance(h, str):
            calls.append(call("jacobian_fd", *args, h=1e-6))
        else:
            calls.append(call("jacobian_fd", *args, h))
    got = yield calls
    verdicts = []
    for g, (name, point, form, h) in zip(got, cases):
        step = "" if h is None else (", h=1e-6" if isinstance(h, str) else f", {fmt(h)}")
        shown = f"np.array({_show(point)}, int)" if form == "int array" else _show(point)
        verdicts.append(expect(g, _analytic(name, point), label=f"jacobian_fd({name.removesuffix('_vec')}, {shown}{step})",
                               rtol=FD_RTOL, atol=FD_ATOL, entries=VECTOR[name][1]))
    return all_of(verdicts)


# ------------------------------------------------------------------------------ max_jacobian_error

@CHECKS.check("max_jacobian_error", points=1)
def max_jacobian_error_right_jacobian(ctx):
    """max_jacobian_error is about 0 (<= 1e-6) for right Jacobians (polar at (4, pi/3) and random points)"""
    rng = ctx.rng
    cases = [("polar_vec", np.array([4.0, np.pi / 3]), "tuple", None)]
    cases += [(name, _vector_point(rng, name), form, h) for name, form, h in
              [("range_bearing_vec", "list", None), ("g_stage_vec", "array", None), ("two_of_three_vec", "tuple", None),
               ("polar_vec", "list", 1e-4), ("range_bearing_vec", "array", None)]]
    got = yield [call("max_jacobian_error", Fn(VECTOR[name][0]), Fn(name), vector_form(p, form),
                      *(() if h is None else (h,))) for name, p, form, h in cases]
    verdicts = []
    for g, (name, p, form, h) in zip(got, cases):
        step = "" if h is None else f", {fmt(h)}"
        label = f"max_jacobian_error({VECTOR[name][0]}, {name}, {_show(p)}{step}) for a right Jacobian"
        verdicts.append(expect(g, 0.0, label=label, rtol=0.0, atol=FD_ATOL))
    return all_of(verdicts)


@CHECKS.check("max_jacobian_error", points=1)
def max_jacobian_error_wrong_jacobian(ctx):
    """max_jacobian_error is max |jac(x) - J(x)| for wrong Jacobians (transposed; a sign slip, of either sign)"""
    rng = ctx.rng
    cases = [("range_bearing_jac_transposed", "range_bearing_vec", planar_point(rng), form)
             for form in ("tuple", "array", "list")]
    for sign, form in ((1.0, "list"), (-1.0, "array"), (-1.0, "tuple")):  # the slip's entry is 2 r sin(theta)
        r, theta = polar_point(rng)
        cases.append(("polar_jac_sign_slip", "polar_vec", np.array([r, sign * abs(theta)]), form))
    got = yield [call("max_jacobian_error", Fn(jac), Fn(f), vector_form(p, form)) for jac, f, p, form in cases]
    verdicts = []
    for g, (jac, f, p, form) in zip(got, cases):
        expected = float(np.max(np.abs(CALLABLES[jac](p) - _analytic(f, p))))
        label = f"max_jacobian_error({jac}, {f}, {_show(p)}) (max |jac - J|, J the true Jacobian)"
        verdicts.append(expect(g, expected, label=label, rtol=FD_RTOL, atol=2 * FD_ATOL))
    return all_of(verdicts)


# ------------------------------------------------------------------------------ best_step

def central_errors(name: str, x: float, hs) -> np.ndarray:
    """|central difference - f'(x)| at every h, computed as the child computes it."""
    f, fprime = CALLABLES[SCALAR[name][0]], CALLABLES[SCALAR[name][1]]
    return np.array([abs((f(x + h) - f(x - h)) / (2 * h) - fprime(x)) for h in hs], dtype=float)


def _best_step_verdict(returned, name: str, x: float, hs: list, label: str):
    problem = value_problem(returned, (), label)
    if problem:
        return fail(problem)
    h = float(returned.as_array())
    matches = [i for i, s in enumerate(hs) if abs(s - h) <= 1e-12 * abs(s)]
    if not matches:
        return fail(f"{label} returned {fmt(h)}, which is not one of the steps in hs.", got=h)
    errors = central_errors(name, x, hs)
    floor = EPS * max(1.0, abs(float(_derivative(name, 1, x))))
    smallest = max(float(errors.min()), floor)
    error = float(errors[matches[0]])
    if error <= BEST_STEP_FACTOR * smallest:
        return passed(got=h)
    best = hs[int(np.argmin(errors))]
    return fail(f"{label} returned h = {fmt(h)}, where the central-difference error is {error:.3g}; at h = {fmt(best)} "
                f"it is {errors.min():.3g}. The answer must be within {BEST_STEP_FACTOR:g}x of the smallest error "
                f"(compare central_difference(f, x, h) with fprime(x) for every h).", expected=best, got=h)


@CHECKS.check("best_step", points=1)
def best_step_worked_example(ctx):
    """best_step(sin, cos, 1, [1e-16, ..., 1e-1]) picks 1e-5 or 1e-6 (graded: within 10x of the smallest error)"""
    hs = [10.0 ** -k for k in range(16, 0, -1)]
    got = yield call("best_step", Fn("sin"), Fn("cos"), 1.0, hs)
    return _best_step_verdict(got, "sin", 1.0, hs, "best_step(sin, cos, 1, [1e-16, ..., 0.1])")


@CHECKS.check("best_step", points=1)
def best_step_random_inputs(ctx):
    """best_step for several f, x and shuffled grids of steps (list, tuple, array): error within 10x of the smallest"""
    rng = ctx.rng
    cases = []
    for name, form in (("exp", "tuple"), ("cubic", "array"), ("sqrt", "list"), ("log", "array"), ("sin", "tuple")):
        hs = 10.0 ** np.linspace(-rng.uniform(13, 15), -rng.uniform(1, 2), int(rng.integers(18, 30)))
        cases.append((name, _point(rng, name), [float(h) for h in rng.permutation(hs)], form))
    got = yield [call("best_step", Fn(SCALAR[name][0]), Fn(SCALAR[name][1]), x,
                      {"list": hs, "tuple": tuple(hs), "array": Array(hs)}[form]) for name, x, hs, form in cases]
    return all_of([_best_step_verdict(g, name, x, hs, f"best_step({name}, {SCALAR[name][1]}, {fmt(x)}, "
                                                      f"{len(hs)} steps from {fmt(min(hs))} to {fmt(max(hs))} as a {form})")
                   for g, (name, x, hs, form) in zip(got, cases)])
