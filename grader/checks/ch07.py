"""Chapter 7: the motion model, its Jacobian F and covariance propagation P' = F P F^T (+ Q).

Closed forms are compared with rtol 1e-9 (atol 1e-12); F also against central differences of the
reference and of the learner's own motion_model, with respect to the state only (v, omega and dt
are extra arguments; see grader/checks/derivatives.py). States keep theta away from multiples of
pi/4, speeds |v| >= 0.5 and dt in [0.05, 0.5], so both heading entries of F are at least 0.005 and
a missing dt, a sign slip or a cos/sin swap changes an entry by far more than the tolerance.
propagate_covariance gets random non-symmetric F (and the motion model's F) and random SPD,
non-diagonal P and Q; F is drawn so that F^T P F differs from F P F^T by at least 10% of the
largest entry, so the transposed product cannot pass. Its output must be symmetric (to 1e-12 of its
largest entry) and positive semi-definite (eigenvalues of its symmetric part >= -1e-12 of that),
also for a singular F; both are computed here from the learner's own output.
"""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import Array, call
from grader.checks.base import chapter_checks
from grader.checks.derivatives import (
    INSIDE,
    Derivative,
    add_derivative_checks,
    add_exact_check,
    angle,
    integer_point,
    time_step,
    vector_form,
    wound,
)
from grader.judging.compare import (
    SINGLE_PRECISION,
    Entries,
    all_of,
    expect,
    fail,
    fmt,
    passed,
    value_problem,
)
from grader.judging.diagnose import Mistake, known
from grader.judging.expected import reference

CHECKS = chapter_checks("ch07")
CHECKS.uses("bicycle_control_jacobian", "bicycle_model")
CHECKS.uses("control_noise_covariance", "bicycle_control_jacobian", "propagate_covariance")
REF = reference("ch07")

STATE = ("x", "y", "theta")
NEW_STATE = ("x'", "y'", "theta'")
S = Entries("state'", rows=NEW_STATE)
F = Entries("F", rows=NEW_STATE, cols=STATE, derivative=True)
RTOL, ATOL = 1e-9, 1e-12
SYMMETRY = SINGLE_PRECISION  # relative to the result: float32 round-off is no asymmetry
TRANSPOSE_GAP = 0.1


def _cov_entries(n: int) -> Entries:
    names = STATE if n == 3 else tuple(f"s{i}" for i in range(n))
    return Entries("P'", rows=names, cols=names, product=True)


def _state(rng: np.random.Generator) -> np.ndarray:
    return np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), angle(rng)])


def _controls(rng: np.random.Generator) -> tuple[float, float, float]:
    """(v, omega, dt): |v| in [0.5, 3], |omega| in [0.2, 1.5], dt in [0.05, 0.5] (never 1)."""
    v = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 3.0))
    omega = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.2, 1.5))
    return v, omega, time_step(rng)


def _mat(m) -> str:
    """A matrix on one line: [[1, 2], [3, 4]]."""
    return "[" + ", ".join("[" + ", ".join(fmt(v) for v in row) + "]" for row in np.atleast_2d(np.asarray(m, dtype=float))) + "]"


def _show(values) -> str:
    return "(" + ", ".join(fmt(v) for v in np.asarray(values, dtype=float).ravel()) + ")"


# ------------------------------------------------------------------------------ motion_model

@CHECKS.check("motion_model", points=1)
def motion_model_worked_example(ctx):
    """motion_model((0, 0, pi/6), v=2, omega=0.5, dt=0.1) is (0.1732, 0.1, 0.5736)"""
    want = REF.motion_model((0.0, 0.0, np.pi / 6), 2.0, 0.5, 0.1)
    got = yield call("motion_model", (0, 0, np.pi / 6), 2.0, 0.5, 0.1)
    return expect(got, want,
                  label="motion_model((0, 0, pi/6), 2, 0.5, 0.1)", rtol=RTOL, atol=ATOL, entries=S)


@CHECKS.check("motion_model", points=2)
def motion_model_random_inputs(ctx):
    """motion_model at random states, speeds, turn rates and time steps (dt != 1; tuples, lists, arrays)"""
    rng = ctx.rng
    cases = [(_state(rng), *_controls(rng), form) for form in ("tuple", "list", "array", "list", "tuple", "array")]
    cases.append((np.array([2.0, -1.0, 1.0]), -1.5, 0.7, 0.25, "int array"))
    expected = [REF.motion_model(s, v, w, dt) for s, v, w, dt, _ in cases]
    slips = [_dt_slips("motion_model", s, v, w, dt) for s, v, w, dt, _ in cases]
    got = yield [call("motion_model", vector_form(s, form), v, w, dt) for s, v, w, dt, form in cases]
    return all_of([expect(g, want, rtol=RTOL, atol=ATOL, entries=S, mistakes=mistakes,
                          label=f"motion_model({_show(s)}, v={fmt(v)}, omega={fmt(w)}, dt={fmt(dt)})")
                   for g, want, mistakes, (s, v, w, dt, form) in zip(got, expected, slips, cases)])


# ------------------------------------------------------------------------------ F_jacobian

@CHECKS.check("F_jacobian", points=2)
def F_worked_example(ctx):
    """F at state (0, 0, pi/6), v=2, omega=0.5, dt=0.1 has F[0,2] = -0.1 and F[1,2] = 0.1732"""
    want = REF.F_jacobian((0.0, 0.0, np.pi / 6), 2.0, 0.5, 0.1)
    got = yield call("F_jacobian", (0, 0, np.pi / 6), 2.0, 0.5, 0.1)
    return expect(got, want, label="F_jacobian((0, 0, pi/6), v=2, omega=0.5, dt=0.1)",
                  rtol=RTOL, atol=ATOL, entries=F)


add_derivative_checks(CHECKS, Derivative(
    forward="motion_model", jacobian="F_jacobian", entries=F,
    args=lambda p, extra: (tuple(float(v) for v in p), *extra),
    reference_forward=lambda p, extra: REF.motion_model(p, *extra),
    reference_jacobian=lambda p, extra: REF.F_jacobian(p, *extra),
    cases=lambda rng: [(_state(rng), _controls(rng)) for _ in range(6)],
    mistakes=lambda p, extra: _dt_slips("F_jacobian", p, *extra),
))
add_exact_check(CHECKS, "F_jacobian", F,
                lambda rng: [((float(x * 100), float(y * 100), wound(th, rng)), *_controls(rng))
                             for x, y, th in (_state(rng) for _ in range(6))],
                REF.F_jacobian, "far from the origin (x, y up to 500), headings many turns round")


@CHECKS.check("F_jacobian", points=1)
def F_integer_and_array_states(ctx):
    """F_jacobian takes the state as a list, a numpy array or an integer array (an integer state drawn for this
    run)"""
    state = [*integer_point(ctx.rng), int(ctx.rng.integers(-3, 4))]
    expected = REF.F_jacobian(state, -1.5, 0.3, 0.2)
    got = yield [call("F_jacobian", state, -1.5, 0.3, 0.2), call("F_jacobian", Array(state, "int64"), -1.5, 0.3, 0.2),
                 call("F_jacobian", Array([float(v) for v in state]), -1.5, 0.3, 0.2)]
    forms = ("a list of ints", "an int64 array", "a float array")
    return all_of([expect(g, expected, label=f"F_jacobian({state} as {form}, -1.5, 0.3, 0.2)",
                          rtol=RTOL, atol=ATOL, entries=F) for g, form in zip(got, forms)])


# ------------------------------------------------------------------------------ propagate_covariance

def spd(rng: np.random.Generator, n: int, scale: float = 1.0) -> np.ndarray:
    """A symmetric positive definite n x n matrix with clearly nonzero off-diagonal entries."""
    a = rng.uniform(-1, 1, (n, n))
    return scale * (a @ a.T + 0.2 * np.eye(n))


def _transpose_sensitive_F(rng: np.random.Generator, P: np.ndarray, singular: bool = False) -> np.ndarray:
    """A non-symmetric F with F P F^T and F^T P F at least TRANSPOSE_GAP (relative) apart."""
    n = P.shape[0]
    while True:
        f = rng.uniform(-2, 2, (n, n))
        if singular:
            f[-1] = rng.uniform(-1, 1) * f[0] + rng.uniform(-1, 1) * f[1]
        right, wrong = REF.propagate_covariance(P, f), REF.propagate_covariance(P, f.T)
        if np.max(np.abs(right - wrong)) >= TRANSPOSE_GAP * np.max(np.abs(right)):
            return f


def _label(P, F, Q=None, how: str = "") -> str:
    n = np.asarray(P).shape[0]
    text = f"propagate_covariance(P, F{how}) with {n}x{n} P = {_mat(P)}, F = {_mat(F)}"
    return text + ("" if Q is None else f", Q = {_mat(Q)}")


def _dt_slips(function: str, state, v: float, omega: float, dt: float) -> list[Mistake]:
    """What a missing or a fixed time step gives (asked of the reference while planning)."""
    reference = getattr(REF, function)
    slips = [Mistake("missing dt", f"dt is missing: every change in one step is a rate times dt (here dt = {fmt(dt)}).",
                     reference(state, v, omega, 1.0))]
    if abs(dt - 0.1) > 1e-9:
        slips.append(Mistake("fixed dt", "a fixed time step of 0.1 is used: take dt from the argument "
                                         f"(here {fmt(dt)}).", reference(state, v, omega, 0.1)))
    if function == "motion_model":
        x, y, th = (float(value) for value in np.asarray(state, dtype=float))
        slips += [Mistake("arc model", "that is the exact constant-turn (arc) motion: the lesson's model is "
                                       "the Euler step x + v cos(theta) dt, y + v sin(theta) dt, theta + omega dt.",
                          REF.arc_motion(state, v, omega, dt)),
                  Mistake("sin and cos swapped", "x moves with sin(theta) and y with cos(theta): the heading is "
                                                 "measured from the x-axis, so x + v cos(theta) dt, y + v sin(theta) "
                                                 "dt.", np.array([x + v * np.sin(th) * dt, y + v * np.cos(th) * dt,
                                                                  th + omega * dt]))]
    return slips


def _matrix(values: np.ndarray, form: str) -> Array:
    """A matrix argument: a float array, or (form "int") an integer array when its entries are whole."""
    return Array(values.tolist(), "int64" if form == "int" else "float64")


@CHECKS.check("propagate_covariance", points=2)
def propagate_worked_example(ctx):
    """propagate_covariance at the lesson's P = diag(0.04, 0.04, 0.01) and the F of F_jacobian's worked example"""
    P = np.diag([0.04, 0.04, 0.01])
    Fm = REF.F_jacobian((0.0, 0.0, np.pi / 6), 2.0, 0.5, 0.1)
    expected = REF.propagate_covariance(P, Fm)  # [[0.0401, -0.000173, -0.001], [-0.000173, 0.0403, 0.001732], ...]
    got = yield [call("propagate_covariance", Array(P.tolist()), Array(Fm.tolist())),
                 call("propagate_covariance", Array(P.tolist()), Array(Fm.tolist()), None)]
    return all_of([expect(g, expected, label=f"propagate_covariance(diag(0.04, 0.04, 0.01), F{how})",
                          rtol=RTOL, atol=ATOL, entries=_cov_entries(3))
                   for g, how in zip(got, ("", ", None"))])


@CHECKS.check("propagate_covariance", points=2)
def propagate_random_matrices(ctx):
    """propagate_covariance = F P F^T (+ Q) for random non-symmetric F and SPD non-diagonal P, Q (n = 2, 3, 4)"""
    rng = ctx.rng
    cases = []
    for n, with_q in ((3, False), (3, True), (2, True), (4, False), (3, True), (2, False)):
        P = spd(rng, n, rng.uniform(0.05, 2.0))
        cases.append((P, _transpose_sensitive_F(rng, P), spd(rng, n, 0.1) if with_q else None, "float"))
    state, controls = _state(rng), _controls(rng)
    P = spd(rng, 3, 0.1)
    cases.append((P, REF.F_jacobian(state, *controls), spd(rng, 3, 0.01), "float"))  # the motion model's own F
    P = np.diag(rng.integers(1, 5, 3).astype(float))  # integer matrices: the contract allows integer arrays
    F_int = rng.integers(-2, 3, (3, 3)).astype(float) + np.diag([1.0, 0.0, 0.0])
    cases.append((P, F_int, np.eye(3), "int"))
    expected = [REF.propagate_covariance(P, Fm, Q) for P, Fm, Q, _ in cases]
    slips = [_propagate_slips(P, Fm, Q) for P, Fm, Q, _ in cases]
    got = yield [call("propagate_covariance", _matrix(P, form), _matrix(Fm, form),
                      *(() if Q is None else (_matrix(Q, form),))) for P, Fm, Q, form in cases]
    return all_of([expect(g, want, label=_label(P, Fm, Q) + (" (integer arrays)" if form == "int" else ""),
                          rtol=RTOL, atol=ATOL, entries=_cov_entries(P.shape[0]), mistakes=mistakes)
                   for g, want, mistakes, (P, Fm, Q, form) in zip(got, expected, slips, cases)])


def _propagate_slips(P, Fm, Q) -> list[Mistake]:
    slips = [Mistake("F^T P F", "your result equals F^T P F: propagation is F P F^T (F on the left).",
                     REF.propagate_covariance(P, np.asarray(Fm).T, Q))]
    F, noise = np.asarray(Fm, dtype=float), 0.0 if Q is None else np.asarray(Q, dtype=float)
    slips += [Mistake("F P", "your result is F P: the covariance of F x is F P F^T, F on both sides.",
                      F @ np.asarray(P, dtype=float) + noise),
              Mistake("F P F", "your result is F P F: the right factor is F^T, F P F^T.",
                      F @ np.asarray(P, dtype=float) @ F + noise)]
    if Q is not None:
        Pf = np.asarray(P, dtype=float)
        slips += [Mistake("missing Q", "Q is missing: add the process noise, F P F^T + Q.",
                          REF.propagate_covariance(P, Fm)),
                  Mistake("Q added twice", "Q is added twice: F P F^T + Q.", F @ Pf @ F.T + 2 * noise),
                  Mistake("Q inside", "Q is propagated with P, F (P + Q) F^T: it is added after, F P F^T + Q.",
                          F @ (Pf + noise) @ F.T)]
    return slips


@CHECKS.check("propagate_covariance", points=1)
def propagate_adds_q_only_when_given(ctx):
    """propagate_covariance(P, F) and (P, F, None) give F P F^T; (P, F, Q) and (P, F, Q=Q) add Q"""
    rng = ctx.rng
    P = spd(rng, 3, 0.5)
    Fm = _transpose_sensitive_F(rng, P)
    Q = spd(rng, 3, 0.2)
    a, f, q = Array(P.tolist()), Array(Fm.tolist()), Array(Q.tolist())
    plain, noisy = REF.propagate_covariance(P, Fm), REF.propagate_covariance(P, Fm, Q)
    got = yield [call("propagate_covariance", a, f), call("propagate_covariance", a, f, None),
                 call("propagate_covariance", a, f, Q=None), call("propagate_covariance", a, f, q),
                 call("propagate_covariance", a, f, Q=q)]
    hows = ("", ", None", ", Q=None", ", Q", ", Q=Q")
    return all_of([expect(g, want, label=_label(P, Fm, Q if i >= 3 else None, how),
                          rtol=RTOL, atol=ATOL, entries=_cov_entries(3))
                   for i, (g, want, how) in enumerate(zip(got, (plain, plain, plain, noisy, noisy), hows))])


@CHECKS.check("propagate_covariance", points=1)
def propagate_result_is_symmetric_psd(ctx):
    """F P F^T is symmetric positive semi-definite, also when F is singular (checked on your output)"""
    rng = ctx.rng
    cases = []
    for n, singular in ((3, False), (3, True), (2, False), (4, True), (3, False)):
        P = spd(rng, n, rng.uniform(0.1, 2.0))
        cases.append((P, _transpose_sensitive_F(rng, P, singular)))
    got = yield [call("propagate_covariance", Array(P.tolist()), Array(Fm.tolist())) for P, Fm in cases]
    for g, (P, Fm) in zip(got, cases):
        problem, _ = _covariance_problem(g, P.shape, _label(P, Fm), "F P F^T")
        if problem:
            return problem
    return passed()


def _covariance_problem(returned, shape: tuple, label: str, product: str) -> tuple:
    """(a failing verdict, None) when the learner's `returned` is not a finite symmetric positive semi-definite
    matrix of `shape`, as `product` always is; else (None, its eigenvalues in ascending order, over its size)."""
    problem = value_problem(returned, shape, label)
    if problem:
        return fail(problem), None
    out = returned.as_array()
    if not np.all(np.isfinite(out)):
        return fail(f"{label} is not finite: {_mat(out)}.", got=out), None
    size = float(np.max(np.abs(out))) or 1.0
    asymmetry = float(np.max(np.abs(out - out.T)))
    if asymmetry > SYMMETRY * size:
        i, j = np.unravel_index(int(np.argmax(np.abs(out - out.T))), out.shape)
        return fail(f"{label} is not symmetric: entry [{i},{j}] = {fmt(out[i, j])} but [{j},{i}] = {fmt(out[j, i])} "
                    f"({product} is always symmetric).", got=out), None
    values = np.linalg.eigvalsh(0.5 * (out + out.T))
    if values[0] < -SYMMETRY * size:
        return fail(f"{label} has a negative eigenvalue {fmt(values[0])}: {product} must be positive "
                    "semi-definite.", got=out), None
    return None, values / size


# ------------------------------------------------------------------------------ the bicycle model's controls

CONTROLS = ("v", "steer")
V = Entries("V", rows=NEW_STATE, cols=CONTROLS, derivative=True)
Q_ENTRIES = _cov_entries(3)
STEER_MAX = 1.0  # the contract: graded steering angles stay within this (tan and 1/cos^2 stay finite)
LESSON_BICYCLE = ((0.0, 0.0, 0.0), 2.0, 0.0, 1.0, 0.1)  # state, v, steer, wheelbase, dt: the contract's point

BICYCLE_SLIPS = {
    "missing dt": "dt is missing: every change in one step is a rate times dt.",
    "steer as turn rate": "the steering angle is used as the turn rate: the heading turns at v tan(steer) / wheelbase.",
    "missing wheelbase": "the turn rate is not divided by the wheelbase: a longer car turns more slowly.",
    "steer for tan(steer)": "the turn rate uses steer where the model has tan(steer).",
    "times the wheelbase": "the turn rate is multiplied by the wheelbase: it is v tan(steer) / wheelbase, so a "
                           "longer car turns more slowly.",
}
CONTROL_SLIPS = {
    "missing 1/cos^2": "d theta'/d steer is missing the derivative of tan: differentiate tan(steer) itself.",
    "1/cos for 1/cos^2": "d theta'/d steer has the derivative of tan as 1/cos(steer): it is 1/cos^2(steer).",
    "tan for 1/cos^2": "d theta'/d steer keeps tan(steer): differentiate it with respect to steer.",
    "missing dt": "dt is missing: every entry is a rate times dt.",
}
NOISE_SLIPS = {
    "sigma not squared": "the standard deviations are used as variances: the control covariance is "
                         "diag(sigma_v^2, sigma_steer^2).",
    "sigmas swapped": "sigma_v and sigma_steer are swapped: the first control is the speed v.",
}


def _bicycle_case(rng: np.random.Generator, near: bool = False) -> tuple:
    """(state, v, steer, wheelbase, dt): |v| in [0.5, 3], |steer| in [0.1, 0.99] (near: [0.8, 0.99], where tan
    steepens), wheelbase in [0.5, 3] at least 0.1 from 1, dt in [0.05, 0.5]."""
    v = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 3.0))
    steer = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.8 if near else 0.1, STEER_MAX - INSIDE))
    wheelbase = float(rng.choice([rng.uniform(0.5, 0.9), rng.uniform(1.1, 3.0)]))
    return _state(rng), v, steer, wheelbase, time_step(rng)


def _bicycle_label(function: str, state, v: float, steer: float, wheelbase: float, dt: float, *rest: float) -> str:
    tail = "".join(f", {name}={fmt(value)}" for name, value in zip(("sigma_v", "sigma_steer"), rest))
    return (f"{function}({_show(state)}, v={fmt(v)}, steer={fmt(steer)}, wheelbase={fmt(wheelbase)}, "
            f"dt={fmt(dt)}{tail})")


@CHECKS.check("bicycle_model", points=1)
def bicycle_model_lesson_point(ctx):
    """bicycle_model((0, 0, 0), v=2, steer=0, wheelbase=1, dt=0.1) is (0.2, 0, 0)"""
    want = REF.bicycle_model(*LESSON_BICYCLE)
    got = yield call("bicycle_model", (0, 0, 0), 2.0, 0.0, 1.0, 0.1)
    return expect(got, want, label=_bicycle_label("bicycle_model", *LESSON_BICYCLE), rtol=RTOL, atol=ATOL, entries=S)


@CHECKS.check("bicycle_model", points=2)
def bicycle_model_random_inputs(ctx):
    """bicycle_model at random states, speeds, steering angles, wheelbases and time steps (tuples, lists, arrays)"""
    cases = [(_bicycle_case(ctx.rng), form) for form in ("tuple", "list", "array", "list", "tuple", "int array")]
    cases[-1] = ((np.array([2.0, -1.0, 1.0]), *cases[-1][0][1:]), "int array")
    expected = [REF.bicycle_model(*case) for case, _ in cases]
    slips = [known(REF.bicycle_mistakes(*case), BICYCLE_SLIPS) for case, _ in cases]
    got = yield [call("bicycle_model", vector_form(case[0], form), *case[1:]) for case, form in cases]
    return all_of([expect(g, want, label=_bicycle_label("bicycle_model", *case), rtol=RTOL, atol=ATOL, entries=S,
                          mistakes=s) for g, want, s, (case, _) in zip(got, expected, slips, cases)])


@CHECKS.check("bicycle_control_jacobian", points=2)
def bicycle_control_jacobian_worked_example(ctx):
    """bicycle_control_jacobian((0, 0, 0), v=2, steer=0, wheelbase=1, dt=0.1) is [[0.1, 0], [0, 0], [0, 0.2]]"""
    want, slips = REF.bicycle_control_jacobian(*LESSON_BICYCLE), REF.bicycle_jacobian_mistakes(*LESSON_BICYCLE)
    got = yield call("bicycle_control_jacobian", (0, 0, 0), 2.0, 0.0, 1.0, 0.1)
    return expect(got, want, label=_bicycle_label("bicycle_control_jacobian", *LESSON_BICYCLE), rtol=RTOL,
                  atol=ATOL, entries=V, mistakes=known(slips, CONTROL_SLIPS))


add_derivative_checks(CHECKS, Derivative(
    forward="bicycle_model", jacobian="bicycle_control_jacobian", entries=V,
    args=lambda p, extra: (vector_form(extra[0], extra[3]), float(p[0]), float(p[1]), extra[1], extra[2]),
    reference_forward=lambda p, extra: REF.bicycle_model(extra[0], p[0], p[1], extra[1], extra[2]),
    reference_jacobian=lambda p, extra: REF.bicycle_control_jacobian(extra[0], p[0], p[1], extra[1], extra[2]),
    cases=lambda rng: [(np.array([v, steer]), (state, wheelbase, dt, form)) for (state, v, steer, wheelbase, dt), form
                       in zip((_bicycle_case(rng) for _ in range(6)), ("tuple", "list", "array") * 2)],
    mistakes=lambda p, extra: known(REF.bicycle_jacobian_mistakes(extra[0], p[0], p[1], extra[1], extra[2]),
                                    CONTROL_SLIPS),
))
add_exact_check(CHECKS, "bicycle_control_jacobian", V,
                lambda rng: [(tuple(float(v) for v in state), *rest)
                             for state, *rest in (_bicycle_case(rng, near=k < 3) for k in range(6))],
                REF.bicycle_control_jacobian, "at steering angles 0.8 to 1 (tan steepens)")


@CHECKS.check("control_noise_covariance", points=1)
def control_noise_lesson_point(ctx):
    """control_noise_covariance at the control Jacobian's point with sigma_v = 0.5, sigma_steer = 0.1"""
    case = (*LESSON_BICYCLE, 0.5, 0.1)
    want, slips = REF.control_noise_covariance(*case), REF.control_noise_mistakes(*case)
    got = yield call("control_noise_covariance", (0, 0, 0), 2.0, 0.0, 1.0, 0.1, 0.5, 0.1)
    return expect(got, want, label=_bicycle_label("control_noise_covariance", *case), rtol=RTOL, atol=ATOL,
                  entries=Q_ENTRIES, mistakes=known(slips, NOISE_SLIPS))


def _noise_cases(rng: np.random.Generator, n: int) -> list[tuple]:
    """Bicycle cases with sigma_v in [0.1, 1] and sigma_steer in [0.02, 0.3], the two never within 0.05."""
    cases = []
    while len(cases) < n:
        sigma_v, sigma_steer = float(rng.uniform(0.1, 1.0)), float(rng.uniform(0.02, 0.3))
        if abs(sigma_v - sigma_steer) >= 0.05:
            cases.append((*_bicycle_case(rng), sigma_v, sigma_steer))
    return cases


@CHECKS.check("control_noise_covariance", points=2)
def control_noise_random_inputs(ctx):
    """control_noise_covariance = V diag(sigma_v^2, sigma_steer^2) V^T at random inputs, V the control Jacobian"""
    cases = _noise_cases(ctx.rng, 6)
    expected = [REF.control_noise_covariance(*case) for case in cases]
    slips = [known(REF.control_noise_mistakes(*case), NOISE_SLIPS) for case in cases]
    got = yield [call("control_noise_covariance", tuple(float(v) for v in case[0]), *case[1:]) for case in cases]
    return all_of([expect(g, want, label=_bicycle_label("control_noise_covariance", *case), rtol=RTOL, atol=ATOL,
                          entries=Q_ENTRIES, mistakes=s) for g, want, s, case in zip(got, expected, slips, cases)])


@CHECKS.check("control_noise_covariance", points=1)
def control_noise_symmetric_rank_two(ctx):
    """control_noise_covariance is symmetric positive semi-definite with rank <= 2 (two controls; checked on your output)"""
    cases = _noise_cases(ctx.rng, 5)
    got = yield [call("control_noise_covariance", tuple(float(v) for v in case[0]), *case[1:]) for case in cases]
    for g, case in zip(got, cases):
        label = _bicycle_label("control_noise_covariance", *case)
        problem, values = _covariance_problem(g, (3, 3), label, "V diag(sigma_v^2, sigma_steer^2) V^T")
        if problem:
            return problem
        if values[0] > SYMMETRY:
            return fail(f"{label} has rank 3 (eigenvalues over the largest entry {_show(values)}): two noisy "
                        "controls spread the state in at most two directions, so their covariance has rank <= 2.",
                        got=g.as_array())
    return passed()
