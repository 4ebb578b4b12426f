"""Chapter 4: the chain rule in matrix form, J_(g o f)(x) = Jg(f(x)) Jf(x).

Closed forms are compared with rtol 1e-9 (atol 1e-12); derivatives also against central differences
(see grader/checks/derivatives.py). compose_jacobian gets catalogue maps (not the lesson's); when its
answer is wrong the check names the usual slip it matches: the product in the wrong order (Jf Jg),
jac_g taken at x instead of f(x), or an elementwise product. The points are chosen so that these
differ from the right answer by at least 0.5 in some entry.
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
    polar_point,
    vector_form,
    wound,
)
from grader.judging.compare import (
    Entries,
    all_of,
    compare_arrays,
    expect,
    fail,
    fmt,
    fmt_array,
    value_problem,
)
from grader.judging.diagnose import known
from grader.judging.expected import reference

CHECKS = chapter_checks("ch04")
CHECKS.uses("pipeline_jacobian", "polar_to_cartesian", "polar_to_cartesian_jacobian", "g_stage", "g_jacobian",
            "compose_jacobian")
CHECKS.uses("lidar_to_world", "polar_to_cartesian")
CHECKS.uses("lidar_to_world_jacobian", "polar_to_cartesian_jacobian", "compose_jacobian", "lidar_to_world")
CHECKS.uses("lidar_pose_jacobian", "polar_to_cartesian", "lidar_to_world")
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


def _slips(candidates: dict) -> list:
    return known(candidates, SLIPS)


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
    """A planar point with u2 at least 0.1 from 1, where g's Jacobian would be symmetric."""
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
add_exact_check(CHECKS, "g_jacobian", JG,
                lambda rng: [(tuple(float(v) for v in planar_point(rng, *((20.0, 60.0) if k % 2 else (0.8, 4.5)))),)
                             for k in range(6)],
                REF.g_jacobian, "far from the origin")


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
                          atol=1e-12, mistakes=_slips(candidates), source=returned)


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
    """pipeline_jacobian at the lesson's point (4, pi/3), the lesson's worked example"""
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
add_exact_check(CHECKS, "pipeline_jacobian", J_PIPE,
                lambda rng: [(float(rng.uniform(0.01, 0.05)), angle(rng)) for _ in range(3)] +
                            [(float(rng.uniform(0.5, 4.0)), wound(angle(rng), rng)) for _ in range(3)],
                REF.pipeline_jacobian, "near r = 0 (r 0.01 to 0.05) and many turns round")


# ------------------------------------------------------------------------------ the lidar-to-world pipeline

W = Entries("w", rows=("world x", "world y"))
J_LIDAR = Entries("J", rows=("world x", "world y"), cols=("r", "theta"), derivative=True)
J_POSE = Entries("J_pose", rows=("world x", "world y"), cols=("px", "py", "phi"), derivative=True)
POSE_FORMS = ("tuple", "list", "array")
R_MIN = 0.3  # the contract: graded ranges are at least this

LIDAR_SLIPS = {
    "missing rotation": "the point is not rotated by the heading phi: turn polar_to_cartesian(r, theta) by phi "
                        "before adding (px, py).",
    "rotation transposed": "the point is rotated by -phi: the rotation by phi is [[cos phi, -sin phi], "
                           "[sin phi, cos phi]].",
    "missing translation": "the robot's position (px, py) is not added.",
}
LIDAR_JACOBIAN_SLIPS = {
    "order": "the product is in the wrong order, J_polar @ R: the chain rule puts the outer stage, the rotation, "
             "on the left.",
    "missing rotation": "that is the polar Jacobian alone: the rotation by phi is a stage of the pipeline too, and "
                        "its Jacobian multiplies from the left.",
    "rotation transposed": "the polar Jacobian is rotated by -phi: the rotation stage turns by phi.",
}
POSE_SLIPS = {
    "missing rotation derivative": "the phi column is zero: turning the robot moves the world point too; "
                                   "differentiate the rotation by phi.",
    "world point": "the phi column turns the world point about the origin: the robot turns about its own position, "
                   "so it is the lidar's point relative to the robot (before adding (px, py)) that turns.",
    "missing identity": "the px and py columns are zero: moving the robot by (dpx, dpy) moves the world point by "
                        "the same amount.",
}


def _lidar_case(rng: np.random.Generator, near: bool = False) -> tuple[float, float, np.ndarray]:
    """(r, theta, pose): r in [0.31, 5] at least 0.1 from 1 (near: r in [0.31, 0.5]), theta, phi and theta + phi
    away from the axes and diagonals, (px, py) in [-5, 5]^2."""
    while True:
        r = rng.uniform(R_MIN + INSIDE, 0.5) if near else rng.uniform(R_MIN + INSIDE, 5.0)
        theta, phi = angle(rng), angle(rng)
        turn = (theta + phi) % (np.pi / 4)
        if abs(r - 1) >= 0.1 and 0.15 <= turn <= np.pi / 4 - 0.15:
            return float(r), float(theta), np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), phi])


def _lidar_label(function: str, r: float, theta: float, pose: np.ndarray, form: str = "tuple") -> str:
    return f"{function}({fmt(r)}, {fmt(theta)}, pose={fmt_array(pose)} as a {form})"


@CHECKS.check("lidar_to_world", points=1)
def lidar_to_world_worked_example(ctx):
    """lidar_to_world(1, 0, pose=(1, 2, pi/2)) is (1, 3)"""
    pose = (1.0, 2.0, np.pi / 2)
    want, slips = REF.lidar_to_world(1, 0, pose), REF.lidar_mistakes(1, 0, pose)
    got = yield call("lidar_to_world", 1, 0, pose)
    return expect(got, want, label="lidar_to_world(1, 0, (1, 2, pi/2))", entries=W, rtol=1e-9,
                  mistakes=known(slips, LIDAR_SLIPS))


@CHECKS.check("lidar_to_world", points=2)
def lidar_to_world_random_points(ctx):
    """lidar_to_world at random returns and poses (the pose as a tuple, list or numpy array)"""
    cases = [(*_lidar_case(ctx.rng), form) for form in POSE_FORMS * 2]
    expected = [REF.lidar_to_world(r, t, pose) for r, t, pose, _ in cases]
    slips = [known(REF.lidar_mistakes(r, t, pose), LIDAR_SLIPS) for r, t, pose, _ in cases]
    got = yield [call("lidar_to_world", r, t, vector_form(pose, form)) for r, t, pose, form in cases]
    return all_of([expect(g, want, label=_lidar_label("lidar_to_world", *case), entries=W, rtol=1e-9, atol=1e-12,
                          mistakes=s) for g, want, s, case in zip(got, expected, slips, cases)])


def _lidar_worked_example(function: str, entries: Entries, slips: str, helps: dict, value: str) -> None:
    """Register `function`'s check at the contract's point, return (1, 0) at pose (1, 2, pi/2), where it is `value`;
    a wrong answer is named by the reference's `slips` there."""
    def worked_example(ctx):
        pose = (1.0, 2.0, np.pi / 2)
        want, mistakes = getattr(REF, function)(1, 0, pose), known(getattr(REF, slips)(1, 0, pose), helps)
        got = yield call(function, 1, 0, pose)
        return expect(got, want, label=f"{function}(1, 0, (1, 2, pi/2))", entries=entries, rtol=1e-9,
                      mistakes=mistakes)

    CHECKS.check(function, 2, description=f"{function}(1, 0, pose=(1, 2, pi/2)) is {value}",
                 id=f"{function}_worked_example")(worked_example)


_lidar_worked_example("lidar_to_world_jacobian", J_LIDAR, "lidar_jacobian_mistakes", LIDAR_JACOBIAN_SLIPS,
                      "[[0, -1], [1, 0]]")


add_derivative_checks(CHECKS, Derivative(
    forward="lidar_to_world", jacobian="lidar_to_world_jacobian", entries=J_LIDAR,
    args=lambda p, extra: (float(p[0]), float(p[1]), vector_form(extra[0], extra[1])),
    reference_forward=lambda p, extra: REF.lidar_to_world(p[0], p[1], extra[0]),
    reference_jacobian=lambda p, extra: REF.lidar_to_world_jacobian(p[0], p[1], extra[0]),
    cases=lambda rng: [(np.array([r, t]), (pose, form)) for (r, t, pose), form
                       in zip((_lidar_case(rng) for _ in range(6)), POSE_FORMS * 2)],
    mistakes=lambda p, extra: known(REF.lidar_jacobian_mistakes(p[0], p[1], extra[0]), LIDAR_JACOBIAN_SLIPS),
))


def _lidar_exact_cases(rng: np.random.Generator) -> list[tuple]:
    """Three returns close to the lidar (r 0.3 to 0.5), and three far from the world's origin (px, py about
    500) with theta and phi many turns round; the pose as a tuple."""
    near = [(r, t, tuple(float(v) for v in pose)) for r, t, pose in (_lidar_case(rng, near=True) for _ in range(3))]
    far = [(r, wound(t, rng), (float(px * 100), float(py * 100), wound(phi, rng)))
           for r, t, (px, py, phi) in (_lidar_case(rng) for _ in range(3))]
    return near + far


LIDAR_EXACT_WHERE = "close to the lidar (r 0.3 to 0.5) and far from the world's origin, many turns round"
add_exact_check(CHECKS, "lidar_to_world_jacobian", J_LIDAR, _lidar_exact_cases, REF.lidar_to_world_jacobian,
                LIDAR_EXACT_WHERE)


_lidar_worked_example("lidar_pose_jacobian", J_POSE, "lidar_pose_mistakes", POSE_SLIPS, "[[1, 0, -1], [0, 1, 0]]")


add_derivative_checks(CHECKS, Derivative(
    forward="lidar_to_world", jacobian="lidar_pose_jacobian", entries=J_POSE,
    args=lambda p, extra: (extra[0], extra[1], vector_form(p, extra[2])),
    reference_forward=lambda p, extra: REF.lidar_to_world(extra[0], extra[1], p),
    reference_jacobian=lambda p, extra: REF.lidar_pose_jacobian(extra[0], extra[1], p),
    cases=lambda rng: [(pose, (r, t, form)) for (r, t, pose), form
                       in zip((_lidar_case(rng) for _ in range(6)), POSE_FORMS * 2)],
    mistakes=lambda p, extra: known(REF.lidar_pose_mistakes(extra[0], extra[1], p), POSE_SLIPS),
))
add_exact_check(CHECKS, "lidar_pose_jacobian", J_POSE, _lidar_exact_cases, REF.lidar_pose_jacobian, LIDAR_EXACT_WHERE)
