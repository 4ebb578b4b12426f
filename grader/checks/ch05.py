"""Chapter 5: finite differences, the numerical Jacobian and "the Jacobian check".

The scalar functions f are catalogue callables with known derivatives, so every difference
quotient is judged against the exact derivative f'(x), within the interval its error must lie in
for a right answer (derived in solutions/oracle/ch05.py, asked through grader.judging.expected):
- central: |error| <= h^2/6 max |f^(3)| on [x-h, x+h] (plus rounding);
- forward: error in h/2 [min f'', max f''] on [x, x+h] (plus rounding): two-sided, so a central
  difference (error ~ h^2) fails it as surely as a backward one (error -h/2 f'').
The steps are 1e-2..1e-1 and the points keep |f''| large, so a forward or backward difference
misses the central tolerance, and a central one the forward interval, by a factor 20 or more.
The lesson's property: over h = 0.1, 0.05, 0.025, 0.0125 the log-log slope of the error is 2 for
central and 1 for forward differences (1.9997..2.0003 and 0.98..1.02 at the points drawn; accepted
within +-0.15).

jacobian_fd is compared with the exact Jacobian of catalogue maps (one R^3 -> R^2, so m != n shows
a transposed result by its shape); with h <= 1e-4 its error is below 1e-8, well inside the
finite-difference tolerance 1e-6 + 1e-6 |J| of grader/checks/derivatives.py. The lesson's worked
example (the polar map at (4, pi/3)) uses the catalogue's polar twin, which has that Jacobian there.
max_jacobian_error must be about 0 (<= 1e-6) for right Jacobians and max |J_wrong - J| (to 2e-6)
for deliberately wrong ones, one of them wrong with a negative sign so that a missing abs shows.
best_step is graded as the contract says: the central-difference error at the returned h must be
within 10x of the smallest error over hs (floored at eps max(1, |f'(x)|), in case one step happens
to hit the exact value).
"""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import Array, Fn, call
from grader.checks.base import chapter_checks
from grader.checks.confusions import STENCIL_HELP, backward_difference
from grader.checks.derivatives import FD_ATOL, FD_RTOL, angle, vector_form
from grader.judging.compare import (
    Entries,
    Verdict,
    all_of,
    fail,
    fmt,
    fmt_array,
    passed,
    value_problem,
)
from grader.judging.compare import expect as _expect
from grader.judging.diagnose import Evidence, Mistake, generated, weigh
from grader.judging.expected import reference
from grader.judging.relations import relations

CHECKS = chapter_checks("ch05")
CHECKS.uses("max_jacobian_error", "jacobian_fd")
CHECKS.uses("best_step", "central_difference")
REF = reference("ch05")


def expect(*args, **kwargs):
    """grader.judging.compare.expect, exact: step conventions differ by less than single-precision round-off."""
    return _expect(*args, exact=True, **kwargs)

SLOPE_STEPS = (0.1, 0.05, 0.025, 0.0125)
SLOPE_TOLERANCE = 0.15
BEST_STEP_FACTOR = 10.0

# catalogue f -> its derivative in the catalogue
DERIVATIVE = {"sin": "cos", "exp": "exp", "cubic": "cubic_prime", "sqrt": "sqrt_prime", "log": "reciprocal"}


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


def _difference_verdict(returned, name: str, x, h: float, function: str, law: dict, what: str):
    """The learner's difference quotient against the exact f'(x) and the interval its error must lie in
    (law: REF.difference_law); a wrong one named by the other difference quotient or a slip of the reference."""
    label = f"{function}({name}, {fmt(x)}, {fmt(h)})"
    problem = value_problem(returned, (), label)
    if problem:
        return fail(problem)
    exact = law["exact"]
    got = float(returned.as_array())
    own, other = ("central", "forward") if function == "central_difference" else ("forward", "central")
    low, high = law[own]
    error = got - exact

    def evidence(only: set[str] | None = None) -> Evidence:  # to the quotient's last digits, as computed
        right = np.asarray(law[f"{own}_value"])
        slips = [_difference_slip(other, law), *_stencil_slips(own, law, h),
                 *relations(np.asarray(got), right, Entries("quotient")), *generated(returned, only)]
        return weigh(np.asarray(got), right, slips, 1e-9, 1e-9)
    if low <= error <= high:
        return Verdict(True, "", exact, got, evidence=evidence)
    verdict = Verdict(False, f"{label}: got {fmt(got)}; the exact derivative is {fmt(exact)}, so the error is "
                             f"{error:.3g}, but {what} must be in [{low:.3g}, {high:.3g}].", exact, got,
                      evidence=evidence)
    return verdict  # its mistake is named when asked (all_of, grading)


def _difference_slip(other: str, law: dict) -> Mistake:
    """The other difference quotient: what a learner who computed it returns."""
    if other == "forward":
        return Mistake("forward difference", "That is the forward difference (f(x+h) - f(x))/h; the central one uses "
                                             "f(x+h) - f(x-h) over 2h.", law["forward_value"])
    return Mistake("central difference", "That is the central difference; the forward one is (f(x+h) - f(x))/h.",
                   law["central_value"])


def _stencil_slips(own: str, law: dict, h: float) -> list[Mistake]:
    """The backward difference where `own` (forward or central) is asked, and for the central one the slip of
    precedence, / 2 * h."""
    formula = "(f(x+h) - f(x-h))/(2h)" if own == "central" else "(f(x+h) - f(x))/h"
    slips = [Mistake("backward difference", STENCIL_HELP["backward difference"].format(own=own, formula=formula),
                     backward_difference(law["forward_value"], law["central_value"]))]
    if own == "central":
        slips.append(Mistake("precedence", STENCIL_HELP["precedence"], law["central_value"] * h * h))
    return slips


def _scalar_cases(rng: np.random.Generator) -> list:
    """(function name, x as passed, h): every catalogue function, one with an integer x."""
    cases = [(name, _point(rng, name), _step(rng)) for name in ("sin", "exp", "cubic", "sqrt", "log", "sin")]
    cases.append(("cubic", int(rng.choice([-2, 2])), _step(rng)))
    return cases


def _difference_check(function: str, what: str, ctx):
    cases = _scalar_cases(ctx.rng)
    laws = [REF.difference_law(name, x, h) for name, x, h in cases]
    got = yield [call(function, Fn(name), x, h) for name, x, h in cases]
    return all_of([_difference_verdict(g, name, x, h, function, law, what)
                   for g, law, (name, x, h) in zip(got, laws, cases)])


def _slope_check(function: str, order: int, ctx):
    rng = ctx.rng
    cases = [(name, _point(rng, name, third=order == 2)) for name in ("sin", "exp", "cubic")]
    exact = [REF.exact_derivative(name, x) for name, x in cases]
    got = yield [[call(function, Fn(name), x, h) for h in SLOPE_STEPS] for name, x in cases]
    steps = np.array(SLOPE_STEPS)
    for values, (name, x), derivative in zip(got, cases, exact):
        label = f"{function}({name}, {fmt(x)}, h)"
        for g, h in zip(values, steps):
            problem = value_problem(g, (), f"{function}({name}, {fmt(x)}, {fmt(h)})")
            if problem:
                return fail(problem)
        errors = np.abs(np.array([float(g.as_array()) for g in values]) - derivative)
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
    law = REF.difference_law("sin", 1.0, 1e-3)
    got = yield call("forward_difference", Fn("sin"), 1.0, 1e-3)
    return expect(got, law["forward_value"], label="forward_difference(sin, 1, 0.001)", rtol=1e-8,
                  mistakes=[_difference_slip("central", law), *_stencil_slips("forward", law, 1e-3)])


@CHECKS.check("forward_difference", points=1)
def forward_difference_random_inputs(ctx):
    """forward_difference misses f'(x) by h/2 f''(c), c in [x, x+h]: sin, exp, a cubic, sqrt, log at random x, h = 0.01..0.1"""
    return (yield from _difference_check("forward_difference", "a forward difference's error h/2 f''(c)", ctx))


@CHECKS.check("forward_difference", points=1)
def forward_difference_error_is_order_h(ctx):
    """halving h halves the forward-difference error: log-log slope 1 over h = 0.1 .. 0.0125"""
    return (yield from _slope_check("forward_difference", 1, ctx))


# ------------------------------------------------------------------------------ central_difference

@CHECKS.check("central_difference", points=1)
def central_difference_worked_example(ctx):
    """central_difference(sin, 1, 1e-5) is cos(1) = 0.5403023 to about 1e-10"""
    want, law = REF.exact_derivative("sin", 1.0), REF.difference_law("sin", 1.0, 1e-5)
    got = yield call("central_difference", Fn("sin"), 1.0, 1e-5)
    return expect(got, want, label="central_difference(sin, 1, 1e-05)", rtol=0.0, atol=1e-10,
                  mistakes=[_difference_slip("forward", law), *_stencil_slips("central", law, 1e-5)])


@CHECKS.check("central_difference", points=1)
def central_difference_random_inputs(ctx):
    """central_difference is within h^2/6 max|f'''| of f'(x): sin, exp, a cubic, sqrt, log at random x, h = 0.01..0.1"""
    return (yield from _difference_check("central_difference", "a central difference's error h^2/6 f'''", ctx))


@CHECKS.check("central_difference", points=1)
def central_difference_uses_the_step_as_given(ctx):
    """central_difference uses h exactly as given: (f(x+h) - f(x-h)) / (2h) to 1e-9 at steps 0.05..0.3, where a halved step shows"""
    rng = ctx.rng
    cases = [(name, _point(rng, name), float(rng.uniform(0.05, 0.3))) for name in ("sin", "exp", "cubic", "sqrt", "log")]
    laws = [REF.difference_law(name, x, h) for name, x, h in cases]
    got = yield [call("central_difference", Fn(name), x, h) for name, x, h in cases]
    return all_of([expect(g, law["central_value"], label=f"central_difference({name}, {fmt(x)}, {fmt(h)})", rtol=1e-9,
                          atol=1e-12, mistakes=[_difference_slip("forward", law), *_stencil_slips("central", law, h)])
                   for g, law, (name, x, h) in zip(got, laws, cases)])


@CHECKS.check("central_difference", points=1)
def central_difference_error_is_order_h_squared(ctx):
    """halving h quarters the central-difference error: log-log slope 2 over h = 0.1 .. 0.0125"""
    return (yield from _slope_check("central_difference", 2, ctx))


# ------------------------------------------------------------------------------ jacobian_fd

# catalogue map -> the names of its Jacobian's entries
VECTOR = {
    "mix_vec": Entries("J", rows=("x y", "x^2 - y"), cols=("x", "y"), derivative=True),
    "shear_vec": Entries("J", rows=("x + y^2", "sin x"), cols=("x", "y"), derivative=True),
    "twist_vec": Entries("J", rows=("e^(x/3) cos y", "x - y^3/3"), cols=("x", "y"), derivative=True),
    "two_of_three_vec": Entries("J", rows=("x y + sin z", "x^2 z - y"), cols=("x", "y", "z"), derivative=True),
    "polar_twin_vec": Entries("J", rows=("x", "y"), cols=("r", "theta"), derivative=True),
    "wave_vec": Entries("J", rows=("y sin x + x^2/2",), cols=("x", "y"), derivative=True),  # one output: 1 x 2
}
RIGHT_JACOBIAN = {"mix_vec": "mix_jac", "shear_vec": "shear_jac", "twist_vec": "twist_jac",
                  "two_of_three_vec": "two_of_three_jac"}


def _vector_point(rng: np.random.Generator, name: str) -> np.ndarray:
    if name == "two_of_three_vec":
        return np.array([*(rng.choice([-1.0, 1.0], 2) * rng.uniform(0.5, 2.5, 2)), angle(rng)])
    if name in ("twist_vec", "wave_vec"):  # cos y, sin y and y all clearly nonzero
        return np.array([rng.uniform(-2.0, 2.0), angle(rng)])
    return rng.choice([-1.0, 1.0], 2) * rng.uniform(0.5, 2.5, 2)  # mix, shear: no zero entry in J


def _show(point) -> str:
    return "(" + ", ".join(fmt(v) for v in np.asarray(point, dtype=float)) + ")"


@CHECKS.check("jacobian_fd", points=2)
def jacobian_fd_worked_example(ctx):
    """jacobian_fd at (4, pi/3) of a map with the polar map's Jacobian there is [[0.5, -3.4641], [0.8660, 2.0]] to 1e-6"""
    want = REF.jacobian_of("polar_twin_vec", (4.0, np.pi / 3))
    got = yield call("jacobian_fd", Fn("polar_twin_vec"), (4, np.pi / 3))
    return expect(got, want, label="jacobian_fd(f, (4, pi/3)) for an f with the polar map's Jacobian there",
                  rtol=0.0, atol=1e-6, entries=VECTOR["polar_twin_vec"])


@CHECKS.check("jacobian_fd", points=2)
def jacobian_fd_random_inputs(ctx):
    """jacobian_fd matches the exact Jacobian (m x n, also 2 x 3) of four maps at random points, given h or not"""
    rng = ctx.rng
    plan = [("mix_vec", "tuple", None), ("shear_vec", "list", None), ("twist_vec", "array", None),
            ("two_of_three_vec", "list", None), ("two_of_three_vec", "array", 1e-4),
            ("twist_vec", "tuple", "h=1e-6"), ("mix_vec", "array", 1e-4)]
    cases = [(name, _vector_point(rng, name), form, h) for name, form, h in plan]
    cases += [("shear_vec", np.array([2.0, -3.0]), "int array", None),
              ("two_of_three_vec", np.array([1.0, -2.0, 2.0]), "int array", None)]
    expected = [REF.jacobian_of(name, point) for name, point, _, _ in cases]
    forward = [REF.jacobian_fd_of(name, point, 1e-6 if isinstance(h, str) else (h or 1e-5), "forward")
               for name, point, _, h in cases]
    calls = []
    for name, point, form, h in cases:
        args = (Fn(name), vector_form(point, form))
        calls.append(call("jacobian_fd", *args) if h is None else
                     call("jacobian_fd", *args, h=1e-6) if isinstance(h, str) else call("jacobian_fd", *args, h))
    got = yield calls
    verdicts = []
    for g, want, slip, (name, point, form, h) in zip(got, expected, forward, cases):
        step = "" if h is None else (", h=1e-6" if isinstance(h, str) else f", {fmt(h)}")
        shown = f"np.array({_show(point)}, int)" if form == "int array" else _show(point)
        verdicts.append(expect(g, want, label=f"jacobian_fd({name.removesuffix('_vec')}, {shown}{step})",
                               rtol=FD_RTOL, atol=FD_ATOL, entries=VECTOR[name], mistakes=[
                                   Mistake("forward difference", FORWARD_HELP, slip)]))
    return all_of(verdicts)


FORWARD_HELP = ("that is a forward difference, (f(x + h e_j) - f(x)) / h: the contract's jacobian_fd is central, "
                "(f(x + h e_j) - f(x - h e_j)) / (2h).")


@CHECKS.check("jacobian_fd", points=1)
def jacobian_fd_uses_the_step_as_given(ctx):
    """jacobian_fd uses h exactly as given (steps 0.05..0.3, where the quotient differs from J), also a 1 x n one-output Jacobian"""
    rng = ctx.rng
    cases = [(name, _vector_point(rng, name), float(rng.uniform(0.05, 0.3)))
             for name in ("twist_vec", "two_of_three_vec", "mix_vec", "wave_vec")]
    expected = [REF.jacobian_fd_of(name, point, h) for name, point, h in cases]
    slips = [[Mistake(form, help, REF.jacobian_fd_of(name, point, h, form)) for form, help in
              (("half step", "the step is halved: the contract's quotient is (f(x + h e_j) - f(x - h e_j)) / (2h), "
                             "x moved by h, not h/2."), ("forward difference", FORWARD_HELP))]
             for name, point, h in cases]
    got = yield [call("jacobian_fd", Fn(name), Array(point.tolist()), h) for name, point, h in cases]
    return all_of([expect(g, want, label=f"jacobian_fd({name.removesuffix('_vec')}, {_show(point)}, {fmt(h)})",
                          rtol=1e-8, atol=1e-10, entries=VECTOR[name], mistakes=mistakes)
                   for g, want, mistakes, (name, point, h) in zip(got, expected, slips, cases)])


# ------------------------------------------------------------------------------ max_jacobian_error

@CHECKS.check("max_jacobian_error", points=1)
def max_jacobian_error_right_jacobian(ctx):
    """max_jacobian_error is about 0 (<= 1e-6) for right Jacobians of four maps at random points, given h or not"""
    rng = ctx.rng
    cases = [(name, _vector_point(rng, name), form, h) for name, form, h in
             [("mix_vec", "tuple", None), ("shear_vec", "list", None), ("twist_vec", "array", None),
              ("two_of_three_vec", "tuple", None), ("mix_vec", "list", 1e-4), ("twist_vec", "array", None)]]
    got = yield [call("max_jacobian_error", Fn(RIGHT_JACOBIAN[name]), Fn(name), vector_form(p, form),
                      *(() if h is None else (h,))) for name, p, form, h in cases]
    verdicts = []
    for g, (name, p, form, h) in zip(got, cases):
        step = "" if h is None else f", {fmt(h)}"
        label = f"max_jacobian_error({RIGHT_JACOBIAN[name]}, {name}, {_show(p)}{step}) for a right Jacobian"
        verdicts.append(expect(g, 0.0, label=label, rtol=0.0, atol=FD_ATOL))
    return all_of(verdicts)


@CHECKS.check("max_jacobian_error", points=1)
def max_jacobian_error_wrong_jacobian(ctx):
    """max_jacobian_error is max |jac(x) - J(x)| for wrong Jacobians (transposed; a sign slip, of either sign)"""
    rng = ctx.rng
    cases = [("twist_jac_transposed", "twist_vec", _vector_point(rng, "twist_vec"), form)
             for form in ("tuple", "array", "list")]
    for sign, form in ((1.0, "list"), (-1.0, "array"), (-1.0, "tuple")):  # the slip's entry is -4x: both signs
        point = _vector_point(rng, "mix_vec")
        cases.append(("mix_jac_sign_slip", "mix_vec", np.array([sign * abs(point[0]), point[1]]), form))
    expected = [REF.jacobian_gap(jac, f, p) for jac, f, p, _ in cases]
    signed = [REF.signed_jacobian_gap(jac, f, p) for jac, f, p, _ in cases]
    got = yield [call("max_jacobian_error", Fn(jac), Fn(f), vector_form(p, form)) for jac, f, p, form in cases]
    return all_of([expect(g, want, label=f"max_jacobian_error({jac}, {f}, {_show(p)}) (max |jac - J|, J the true "
                                         "Jacobian)", rtol=FD_RTOL, atol=2 * FD_ATOL, mistakes=[
                              Mistake("signed difference", "take the absolute value: the Jacobian check is "
                                                           "max |jac(x) - J(x)|, and a wrong entry may be too small.",
                                      value)])
                   for g, want, value, (jac, f, p, _) in zip(got, expected, signed, cases)])


# ------------------------------------------------------------------------------ best_step

ERROR_FOR_STEP = Mistake("the error for the step", "that is an error of the central difference: return the step h "
                                                   "in hs that gives the smallest one.")


def _best_step_verdict(returned, errors_and_floor: tuple, hs: list, label: str):
    """The returned h must be one of hs, its error within BEST_STEP_FACTOR of the smallest
    (errors_and_floor: REF.best_step_errors)."""
    problem = value_problem(returned, (), label)
    if problem:
        return fail(problem)
    h = float(returned.as_array())
    errors, floor = np.asarray(errors_and_floor[0], dtype=float), errors_and_floor[1]
    smallest = max(float(errors.min()), floor)

    def chosen(value: float) -> int | None:
        """The position in hs of a step within 1e-12 of `value`, if it is one; None if it is not."""
        return next((i for i, s in enumerate(hs) if abs(s - value) <= 1e-12 * abs(s)), None)

    def acceptable(value: float) -> bool:
        i = chosen(value)
        return i is not None and float(errors[i]) <= BEST_STEP_FACTOR * smallest

    def evidence(only: set[str] | None = None) -> Evidence:
        """The slips of the reference that return no acceptable step, against the learner's step."""
        found = Evidence()
        for slip in generated(returned, only):
            if np.size(slip.value) != 1 or acceptable(float(np.asarray(slip.value, dtype=float))):
                continue
            value = float(np.asarray(slip.value, dtype=float))
            if abs(value - h) <= 1e-12 * max(abs(value), 1e-300):
                found.matched[slip.id] = slip
            else:
                found.ruled_out.add(slip.id)
        return found
    if chosen(h) is None:
        verdict = Verdict(False, f"{label} returned {fmt(h)}, which is not one of the steps in hs.", got=h,
                          evidence=evidence)
        if any(abs(h - e) <= 1e-9 * abs(e) for e in errors):
            verdict.also(lambda only: Evidence({ERROR_FOR_STEP.id: ERROR_FOR_STEP}))
    elif acceptable(h):
        return Verdict(True, "", got=h, evidence=evidence)
    else:
        best = hs[int(np.argmin(errors))]
        error = float(errors[chosen(h)])
        verdict = Verdict(False, f"{label} returned h = {fmt(h)}, where the central-difference error is {error:.3g}; "
                                 f"at h = {fmt(best)} it is {errors.min():.3g}. The answer must be within "
                                 f"{BEST_STEP_FACTOR:g}x of the smallest error (compare central_difference(f, x, h) "
                                 "with fprime(x) for every h).", expected=best, got=h, evidence=evidence)
    return verdict  # its mistake is named when asked (all_of, grading)


@CHECKS.check("best_step", points=1)
def best_step_worked_example(ctx):
    """best_step(sin, cos, 1, [1e-16, ..., 1e-1]) picks 1e-5 or 1e-6 (graded: within 10x of the smallest error)"""
    hs = [10.0 ** -k for k in range(16, 0, -1)]
    errors = REF.best_step_errors("sin", "cos", 1.0, hs)
    got = yield call("best_step", Fn("sin"), Fn("cos"), 1.0, hs)
    return _best_step_verdict(got, errors, hs, "best_step(sin, cos, 1, [1e-16, ..., 0.1])")


@CHECKS.check("best_step", points=1)
def best_step_random_inputs(ctx):
    """best_step for several f, x and shuffled grids of steps (list, tuple, array): error within 10x of the smallest"""
    rng = ctx.rng
    cases = []
    for name, form in (("exp", "tuple"), ("cubic", "array"), ("sqrt", "list"), ("log", "array"), ("sin", "tuple")):
        hs = 10.0 ** np.linspace(-rng.uniform(13, 15), -rng.uniform(1, 2), int(rng.integers(18, 30)))
        cases.append((name, _point(rng, name), [float(h) for h in rng.permutation(hs)], form))
    errors = [REF.best_step_errors(name, DERIVATIVE[name], x, hs) for name, x, hs, _ in cases]
    got = yield [call("best_step", Fn(name), Fn(DERIVATIVE[name]), x,
                      {"list": hs, "tuple": tuple(hs), "array": Array(hs)}[form]) for name, x, hs, form in cases]
    return all_of([_best_step_verdict(g, e, hs, f"best_step({name}, {DERIVATIVE[name]}, {fmt(x)}, "
                                                f"{len(hs)} steps from {fmt(min(hs))} to {fmt(max(hs))} as a {form})")
                   for g, e, (name, x, hs, form) in zip(got, errors, cases)])
