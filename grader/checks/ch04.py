"""Chapter 4: the chain rule in matrix form, J_(g o f)(x) = Jg(f(x)) Jf(x).

Closed forms are compared with rtol 1e-9 (atol 1e-12); derivatives also against central differences
(see grader/checks/derivatives.py). compose_jacobian gets catalogue maps (not the lesson's); when its
answer is wrong the check names the usual slip it matches: the product in the wrong order (Jf Jg),
jac_g taken at x instead of f(x), or an elementwise product. The points are chosen so that these
differ from the right answer by at least 0.5 in some entry.
"""

from __future__ import annotations

import numpy as np

from grader.checks.base import chapter_checks
from grader.checks.derivatives import Derivative, add_derivative_checks, planar_point, polar_point, vector_form
from grader.compare import Entries, all_of, compare_arrays, expect, fail, fmt_array, value_problem
from grader.diagnose import Mistake
from grader.expected import reference
from grader.wire import Fn, call

CHECKS = chapter_checks("ch04")
CHECKS.uses("pipeline_jacobian", "polar_to_cartesian", "polar_to_cartesian_jacobian", "g_stage", "g_jacobian",
            "compose_jacobian")
REF = reference("ch04")

G = Entries("g", rows=("u1^2 + u2", "u1 u2"))
JG = Entries("Jg", rows=("g1", "g2"), cols=("u1", "u2"), derivative=True)
J_PIPE = Entries("J", rows=("g1", "g2"), cols=("r", "theta"), derivative=True)
J_COMPOSED = Entries("J", rows=("out 1", "out 2"), cols=("x1", "x2"), derivative=True)
FORMS = ("tuple", "list", "array")

# (f, jac_f, jac_g) from the catalogue: every one maps 2-vectors to 2-vectors
COMPOSITIONS = (("mix_vec", "mix_jac", "shear_jac"), ("shear_vec", "shear_jac", "twist_jac"),
                ("twist_vec", "twist_jac", "mix_jac"), ("mix_vec", "mix_jac", "mix_jac"))
SLIP_GAP = 0.5
SLIPS = {"order": "the product is in the wrong order, Jf(x) @ Jg(f(x)): the chain rule is Jg(f(x)) @ Jf(x).",
         "at_x": "the outer Jacobian is taken at x: evaluate jac_g at f(x), the point the first stage maps x to.",
         "at_x_and_order": "jac_g is taken at x and the product is in the wrong order: Jg(f(x)) @ Jf(x).",
         "elementwise": "that is an elementwise product (*): the chain rule multiplies matrices (@)."}


def _slips(candidates: dict) -> list[Mistake]:
    return [Mistake(name, SLIPS[name], candidates[name]) for name in SLIPS if name in candidates]


@CHECKS.check("g_stage", points=2)
def g_stage_random_points(ctx):
    """g_stage(u) = (u1^2 + u2, u1 u2) at random points, u as a tuple, list or numpy array (also of integers)"""
    rng = ctx.rng
    cases = [(planar_point(rng), form) for form in (*FORMS, "tuple", "array")] + [(np.array([-3.0, 2.0]), "int array")]
    expected = [REF.g_stage(u) for u, _ in cases]
    got = yield [call("g_stage", vector_form(u, form)) for u, form in cases]
    return all_of([expect(g, want, label=f"g_stage({fmt_array(u)} as a {form})", entries=G, rtol=1e-9, atol=1e-12)
                   for g, want, (u, form) in zip(got, expected, cases)])


def _u_point(rng: np.random.Generator) -> np.ndarray:
    """A planar point with u2 at least 0.1 from 1, where Jg = [[2u1, 1], [u2, u1]] would be symmetric."""
    while True:
        u = planar_point(rng)
        if abs(u[1] - 1.0) >= 0.1:
            return u


@CHECKS.check("g_jacobian", points=1)
def g_jacobian_worked_example(ctx):
    """g_jacobian at u = (2, 3.4641) is [[4, 1], [3.4641, 2]]"""
    want = REF.g_jacobian((2, 3.4641))
    got = yield call("g_jacobian", (2, 3.4641))
    return expect(got, want, label="g_jacobian((2, 3.4641))", entries=JG, rtol=1e-9)


add_derivative_checks(CHECKS, Derivative(
    forward="g_stage", jacobian="g_jacobian", entries=JG,
    args=lambda p, extra: (vector_form(p, extra[0]),),
    reference_forward=lambda p, extra: REF.g_stage(p),
    reference_jacobian=lambda p, extra: REF.g_jacobian(p),
    cases=lambda rng: [(_u_point(rng), (form,)) for form in FORMS * 2],
))


def _slips_show(candidates: dict) -> bool:
    right = candidates["right"]
    return all(np.max(np.abs(candidates[slip] - right)) >= SLIP_GAP for slip in SLIPS)


def _compose_cases(rng: np.random.Generator, compositions: tuple) -> list:
    """(f, jac_f, jac_g, x, form, candidates) for each composition, at a point where every usual slip is off
    by >= SLIP_GAP; candidates: the right answer and each slip's result (REF.compose_candidates)."""
    cases = []
    for f, jac_f, jac_g in compositions:
        for _ in range(1000):
            x = planar_point(rng, 0.8, 2.5)
            candidates = REF.compose_candidates(f, jac_f, jac_g, x)
            if _slips_show(candidates):
                cases.append((f, jac_f, jac_g, x, FORMS[len(cases) % len(FORMS)], candidates))
                break
        else:
            raise RuntimeError(f"no point found where the slips of {f}, {jac_f}, {jac_g} show")
    return cases


def _compose_verdict(returned, f: str, jac_f: str, jac_g: str, x: np.ndarray, form: str, candidates: dict):
    label = f"compose_jacobian({f}, {jac_f}, {jac_g}, x={fmt_array(x)} as a {form})"
    problem = value_problem(returned, (2, 2), label)
    if problem:
        return fail(problem, expected=candidates["right"])
    return compare_arrays(returned.as_array(), candidates["right"], label=label, entries=J_COMPOSED, rtol=1e-9,
                          atol=1e-12, mistakes=_slips(candidates))


@CHECKS.check("compose_jacobian", points=2)
def compose_jacobian_random_inputs(ctx):
    """compose_jacobian = Jg(f(x)) @ Jf(x) for four pairs of catalogue maps at random points"""
    cases = _compose_cases(ctx.rng, COMPOSITIONS + COMPOSITIONS[:2])
    got = yield [call("compose_jacobian", Fn(f), Fn(jf), Fn(jg), vector_form(x, form)) for f, jf, jg, x, form, _ in cases]
    return all_of([_compose_verdict(g, *case) for g, case in zip(got, cases)])


@CHECKS.check("compose_jacobian", points=1)
def compose_jacobian_order_and_point(ctx):
    """compose_jacobian(twist, J_twist, J_mix, x) is Jg(f(x)) Jf(x): not Jf Jg, and Jg taken at f(x), not at x"""
    cases = _compose_cases(ctx.rng, (("twist_vec", "twist_jac", "mix_jac"),) * 3)
    got = yield [call("compose_jacobian", Fn(f), Fn(jf), Fn(jg), vector_form(x, form)) for f, jf, jg, x, form, _ in cases]
    return all_of([_compose_verdict(g, *case) for g, case in zip(got, cases)])


@CHECKS.check("pipeline_jacobian", points=2)
def pipeline_jacobian_worked_example(ctx):
    """pipeline_jacobian(4, pi/3) is [[2.866, -11.856], [3.464, -8.000]]"""
    want, slips = REF.pipeline_jacobian(4, np.pi / 3), REF.pipeline_mistakes(4, np.pi / 3)
    got = yield call("pipeline_jacobian", 4, np.pi / 3)
    return expect(got, want, label="pipeline_jacobian(4, pi/3)", entries=J_PIPE, rtol=1e-9, mistakes=_slips(slips))


add_derivative_checks(CHECKS, Derivative(
    forward="g_stage", jacobian="pipeline_jacobian", entries=J_PIPE,
    args=lambda p, extra: (float(p[0]), float(p[1])),
    forward_args=lambda p, extra: (REF.polar_to_cartesian(*p),),  # your g_stage after the (reference) polar map
    forward_text="g_stage(polar_to_cartesian(r, theta))",
    reference_forward=lambda p, extra: REF.pipeline_forward(*p),
    reference_jacobian=lambda p, extra: REF.pipeline_jacobian(*p),
    cases=lambda rng: [(polar_point(rng, 4.0), ()) for _ in range(6)],
    mistakes=lambda p, extra: _slips(REF.pipeline_mistakes(*p)),
))
