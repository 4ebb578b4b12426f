"""Chapter 9: choose your tool: finite-difference gradient and Hessian, and reading the Hessian.

gradient_fd is compared with the exact gradient of catalogue functions (y sin x + x^2/2, a bowl,
a 3-D cubic and Rosenbrock) with the finite-difference tolerance 1e-6 + 1e-6 |g| of
grader/checks/derivatives.py: at h = 1e-5 truncation h^2/6 M3 and rounding eps M0/h stay below
2e-7 on the sampled domain (|x| <= 1.5 for Rosenbrock).

hessian_fd is the central difference of a central-difference gradient, both with step h, so
(derivation as in derivatives.py, applied twice): truncation h^2/6 from each level, h^2/3 M4 in
all (M4 bounds fourth derivatives: 0 for the quadratic and the cubic, 2400 for Rosenbrock), and
the gradient's rounding error eps (M0 + |x| M1)/h differenced once more over 2h, eps (M0 + |x| M1)/h^2
(M0: the size of f's terms, M1: of its gradient). The tolerance is twice the sum of both, with a
factor 4 on the rounding for the argument roundings: about 3e-6 at the worked example, up to 1.6e-3
for Rosenbrock (entries up to 2700); a forward outer difference is off by h/2 |f'''|, at least 3e-4
for the cubic and Rosenbrock. The output must be exactly symmetric, bit for bit: (J + J^T)/2 is (IEEE
addition commutes), an unsymmetrised finite-difference Hessian nearly never is at the larger steps
h = 0.1..0.3 used there (its two off-diagonal entries are rounded differently).

classify_critical_point returns a string, compared here as a string (no number is involved).
Matrices are built as Q diag(lambda) Q^T with a random rotation Q, so their eigenvalues are the
chosen ones to within 1e-13 of the largest; the threshold cases put eigenvalues at 0.5-0.8x and at
3x the threshold 1e-8 max(1, largest), with largest both below and above 1.
"""

from __future__ import annotations

import numpy as np

from grader.boundary.wire import Array, Fn, call
from grader.checks.base import chapter_checks
from grader.checks.derivatives import (
    FD_ATOL,
    FD_RTOL,
    integer_point,
    planar_point,
    vector_form,
)
from grader.judging.compare import (
    Entries,
    Verdict,
    all_of,
    expect,
    fail,
    fmt,
    fmt_array,
    passed,
    value_problem,
)
from grader.judging.diagnose import Evidence, Mistake, generated, known, weigh_text
from grader.judging.expected import reference

CHECKS = chapter_checks("ch09")
CHECKS.uses("hessian_fd", "gradient_fd", "jacobian_fd")
REF = reference("ch09")

EPS = float(np.finfo(float).eps)
NAMES = ("x", "y", "z")
CLASSES = ("minimum", "maximum", "saddle", "degenerate")


def _grad_entries(n: int) -> Entries:
    return Entries("gradient", rows=tuple(f"d f/d {v}" for v in NAMES[:n]))


def _hess_entries(n: int) -> Entries:
    return Entries("Hessian", rows=NAMES[:n], cols=NAMES[:n])


def _mat(m) -> str:
    """A matrix on one line: [[1, 2], [3, 4]]."""
    return "[" + ", ".join("[" + ", ".join(fmt(v) for v in row) + "]" for row in np.atleast_2d(np.asarray(m, dtype=float))) + "]"


def _show(values) -> str:
    return "(" + ", ".join(fmt(v) for v in np.asarray(values, dtype=float).ravel()) + ")"


def _point(rng: np.random.Generator, name: str) -> np.ndarray:
    if name == "saddle3_vec":
        return rng.choice([-1.0, 1.0], 3) * rng.uniform(0.4, 2.0, 3)
    if name == "rosenbrock_vec":
        return np.array([rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 1.5), rng.uniform(-1.0, 2.0)])
    return planar_point(rng)


# ------------------------------------------------------------------------------ gradient_fd

@CHECKS.check("gradient_fd", points=1)
def gradient_fd_random_points(ctx):
    """gradient_fd matches the analytic gradient of four functions (2-D and 3-D) at random points, given h or not"""
    rng = ctx.rng
    plan = [("wave_vec", "tuple", None), ("bowl_vec", "list", None), ("saddle3_vec", "array", None),
            ("rosenbrock_vec", "list", None), ("saddle3_vec", "tuple", 1e-4), ("rosenbrock_vec", "array", "h=1e-6"),
            ("wave_vec", "array", None)]
    cases = [(name, _point(rng, name), form, h) for name, form, h in plan]
    expected = [REF.gradient_of(name, p) for name, p, _, _ in cases]
    slips = [_forward_slip(name, p, 1e-6 if isinstance(h, str) else (h or 1e-5)) for name, p, _, h in cases]
    calls = []
    for name, p, form, h in cases:
        args = (Fn(name), vector_form(p, form))
        calls.append(call("gradient_fd", *args) if h is None else
                     call("gradient_fd", *args, h=1e-6) if isinstance(h, str) else call("gradient_fd", *args, h))
    got = yield calls
    verdicts = []
    for g, want, slip, (name, p, form, h) in zip(got, expected, slips, cases):
        step = "" if h is None else (", h=1e-6" if isinstance(h, str) else f", {fmt(h)}")
        verdicts.append(expect(g, want, label=f"gradient_fd({name}, {_show(p)}{step})",
                               rtol=FD_RTOL, atol=FD_ATOL, entries=_grad_entries(p.size), mistakes=[slip], exact=True))
    return all_of(verdicts)


@CHECKS.check("gradient_fd", points=1)
def gradient_fd_integer_input(ctx):
    """gradient_fd converts integer x to float first: integer points (drawn for this run) as an int64 array, a
    list and a tuple"""
    p, q, r = (list(integer_point(ctx.rng)) for _ in range(3))
    three = [*integer_point(ctx.rng), int(ctx.rng.integers(-2, 3))]
    cases = [("wave_vec", p, Array(p, "int64")), ("wave_vec", q, q), ("rosenbrock_vec", r, tuple(r)),
             ("saddle3_vec", three, Array(three, "int64"))]
    expected = [REF.gradient_of(name, point) for name, point, _ in cases]
    slips = [_forward_slip(name, point, 1e-5) for name, point, _ in cases]
    calls = [call("gradient_fd", Fn(name), passed) for name, _, passed in cases]
    got = yield calls
    return all_of([expect(g, want, label=c.label, rtol=FD_RTOL, atol=FD_ATOL, entries=_grad_entries(len(want)), exact=True,
                          mistakes=[slip, Mistake("integer steps", "all zeros: an integer array cannot hold x + h; "
                                                                   "convert x to float first.", np.zeros(len(want)))])
                   for g, want, slip, c in zip(got, expected, slips, calls)])


@CHECKS.check("gradient_fd", points=1)
def gradient_fd_uses_the_step_as_given(ctx):
    """gradient_fd uses h exactly as given (steps 0.05..0.3, where the quotient differs from the gradient), 2-D and 3-D"""
    rng = ctx.rng
    cases = [(name, _point(rng, name), float(rng.uniform(0.05, 0.3)))
             for name in ("wave_vec", "saddle3_vec", "rosenbrock_vec", "bowl_vec")]
    expected = [REF.gradient_fd_of(name, point, h) for name, point, h in cases]
    slips = [_forward_slip(name, point, h) for name, point, h in cases]
    got = yield [call("gradient_fd", Fn(name), Array(point.tolist()), h) for name, point, h in cases]
    return all_of([expect(g, want, label=f"gradient_fd({name}, {_show(point)}, {fmt(h)})", rtol=1e-8, atol=1e-10,
                          entries=_grad_entries(point.size), mistakes=[slip], exact=True)
                   for g, want, slip, (name, point, h) in zip(got, expected, slips, cases)])


def _forward_slip(name: str, point, h: float) -> Mistake:
    return Mistake("forward difference", "that is a forward difference, (f(x + h e_j) - f(x)) / h: gradient_fd is "
                                         "central, (f(x + h e_j) - f(x - h e_j)) / (2h).",
                   REF.gradient_fd_of(name, point, h, "forward"))


# ------------------------------------------------------------------------------ hessian_fd

def _hessian_expected(name: str, p: np.ndarray, h: float) -> tuple:
    """(the exact Hessian, the tolerance a right hessian_fd with step h meets), asked while planning."""
    return REF.hessian_of(name, p), REF.hessian_tolerance(name, p, h)


def _hessian_verdict(returned, wanted: tuple, label: str) -> Verdict:
    hessian, tolerance = wanted
    return expect(returned, hessian, label=label, rtol=0.0, atol=tolerance, entries=_hess_entries(len(hessian)))


@CHECKS.check("hessian_fd", points=1)
def hessian_fd_worked_example(ctx):
    """hessian_fd at (1, 2) of a function with the Hessian of x^2 + x y there is [[2, 1], [1, 0]]"""
    wanted = _hessian_expected("hessian_twin_vec", np.array([1.0, 2.0]), 1e-4)
    got = yield call("hessian_fd", Fn("hessian_twin_vec"), (1, 2))
    return _hessian_verdict(got, wanted, "hessian_fd(f, (1, 2)) for an f with the Hessian of x^2 + x y there")


@CHECKS.check("hessian_fd", points=1)
def hessian_fd_random_points(ctx):
    """hessian_fd matches the analytic Hessian of a bowl, a 3-D cubic and Rosenbrock at random points, given h or not"""
    rng = ctx.rng
    plan = [("saddle3_vec", "tuple", None), ("rosenbrock_vec", "list", None), ("bowl_vec", "array", None),
            ("saddle3_vec", "array", 1e-3), ("rosenbrock_vec", "tuple", "h=1e-3"), ("saddle3_vec", "list", None)]
    cases = [(name, _point(rng, name), form, h) for name, form, h in plan]
    wanted = [_hessian_expected(name, p, 1e-4 if h is None else 1e-3) for name, p, _, h in cases]
    calls = []
    for name, p, form, h in cases:
        args = (Fn(name), vector_form(p, form))
        calls.append(call("hessian_fd", *args) if h is None else
                     call("hessian_fd", *args, h=1e-3) if isinstance(h, str) else call("hessian_fd", *args, h))
    got = yield calls
    verdicts = []
    for g, w, (name, p, form, h) in zip(got, wanted, cases):
        shown = "" if h is None else (", h=1e-3" if isinstance(h, str) else ", 0.001")
        verdicts.append(_hessian_verdict(g, w, f"hessian_fd({name}, {_show(p)}{shown})"))
    return all_of(verdicts)


@CHECKS.check("hessian_fd", points=1)
def hessian_fd_uses_the_step_as_given(ctx):
    """hessian_fd uses h exactly as given, in both differences (steps 0.1..0.3, where a halved step shows), 2-D and 3-D"""
    rng = ctx.rng
    cases = [(name, _point(rng, name), float(rng.uniform(0.1, 0.3))) for name in ("saddle3_vec", "rosenbrock_vec",
                                                                                  "wave_vec")]
    expected = [REF.hessian_fd_of(name, p, h) for name, p, h in cases]
    got = yield [call("hessian_fd", Fn(name), Array(p.tolist()), h) for name, p, h in cases]
    return all_of([expect(g, want, label=f"hessian_fd({name}, {_show(p)}, {fmt(h)})", rtol=1e-8,
                          atol=1e-10 * max(1.0, float(np.max(np.abs(want)))), entries=_hess_entries(p.size), exact=True)
                   for g, want, (name, p, h) in zip(got, expected, cases)])


@CHECKS.check("hessian_fd", points=1)
def hessian_fd_is_symmetric(ctx):
    """hessian_fd returns an exactly symmetric matrix (symmetrised: (J + J^T)/2), checked on your output"""
    rng = ctx.rng
    cases = [("saddle3_vec", 0.3), ("rosenbrock_vec", 0.1), ("saddle3_vec", 0.3), ("saddle3_vec", 0.2),
             ("rosenbrock_vec", 0.1)]
    cases = [(name, _point(rng, name), h) for name, h in cases]
    got = yield [call("hessian_fd", Fn(name), Array(p.tolist()), h) for name, p, h in cases]
    for g, (name, p, h) in zip(got, cases):
        label = f"hessian_fd({name}, {_show(p)}, {fmt(h)})"
        problem = value_problem(g, (p.size, p.size), label)
        if problem:
            return fail(problem)
        out = g.as_array()
        gap = np.abs(out - out.T)
        if not np.all(np.isfinite(out)) or gap.max() > 0:
            i, j = np.unravel_index(int(np.argmax(gap)), gap.shape)
            verdict = fail(f"{label} is not exactly symmetric: Hessian[{i},{j}] = {float(out[i, j])!r} but "
                           f"Hessian[{j},{i}] = {float(out[j, i])!r}.", got=out)
            verdict.name(Mistake("not symmetrised", "a finite-difference Jacobian of the gradient is only nearly "
                                                    "symmetric: return its symmetric part, (J + J^T) / 2."))
            return verdict
    return passed()


# ------------------------------------------------------------------------------ classify_critical_point

CLASSIFY_SLIPS = {
    "degenerate before saddle": "a zero eigenvalue is tested first: eigenvalues of both signs make a saddle "
                                "whatever else is zero, so test for both signs before a zero.",
    "no tolerance": "an eigenvalue is compared with 0 exactly: round-off leaves a zero eigenvalue at about 1e-16, "
                    "so treat one as zero when its size <= 1e-8 max(1, largest size).",
    "absolute tolerance": "the tolerance is an absolute 1e-8: it is relative, 1e-8 max(1, largest size), so that "
                          "a large Hessian's round-off counts as zero too.",
    "not symmetrised": "the matrix is classified as given: symmetrise it first, (A + A^T)/2; its eigenvalues "
                       "decide.",
}


def _classify_slips(m: np.ndarray) -> list[Mistake]:
    return known(REF.classify_mistakes(m), CLASSIFY_SLIPS)


def expect_text(returned, expected: str, *, label: str, mistakes: list[Mistake] = ()) -> Verdict:
    """The call must return exactly the string `expected`; a wrong one is named by the first of `mistakes` (then
    of the slips generated from the reference) it equals."""
    if not returned.ok:
        return fail(returned.problem(), expected=expected)
    text = returned.text
    if text is None:
        shown = fmt_array(returned.as_array()) if returned.as_array() is not None else returned.type_name
        return fail(f"{label} returned {shown}; expected the string {expected!r}.", expected=expected)

    def evidence(only: set[str] | None = None) -> Evidence:
        return weigh_text(text, expected, [*mistakes, *generated(returned, only)])
    if text == expected:
        return Verdict(True, "", expected, text, evidence=evidence)
    hint = ""
    if text.strip().lower() == expected:
        hint = " (exactly, in lower case and without spaces)"
    elif text not in CLASSES:
        hint = f" (the answer is one of {', '.join(repr(c) for c in CLASSES)})"
    verdict = Verdict(False, f"{label} returned {text!r}; expected {expected!r}{hint}.", expected, text,
                      evidence=evidence)
    return verdict  # its mistake is named when asked (all_of, grading)


def with_eigenvalues(rng: np.random.Generator, eigenvalues) -> np.ndarray:
    """Q diag(eigenvalues) Q^T for a random rotation Q: symmetric, non-diagonal, these eigenvalues."""
    n = len(eigenvalues)
    q, r = np.linalg.qr(rng.standard_normal((n, n)))
    q = q * np.sign(np.diag(r))
    m = q @ np.diag(eigenvalues) @ q.T
    return 0.5 * (m + m.T)


def _classify_label(m: np.ndarray, eigenvalues=None) -> str:
    text = f"classify_critical_point({_mat(m)})"
    return text if eigenvalues is None else f"{text} (eigenvalues {', '.join(f'{v:.3g}' for v in eigenvalues)})"


@CHECKS.check("classify_critical_point", points=1)
def classify_worked_example(ctx):
    """classify_critical_point(np.array([[2, 1], [1, 0]])) is "saddle" (the Hessian of x^2 + x y)"""
    example = np.array([[2.0, 1.0], [1.0, 0.0]])
    want, slips = REF.classify_critical_point(example), _classify_slips(example)
    got = yield call("classify_critical_point", Array([[2, 1], [1, 0]], "int64"))
    return expect_text(got, want, label="classify_critical_point(np.array([[2, 1], [1, 0]]))", mistakes=slips)


@CHECKS.check("classify_critical_point", points=2)
def classify_all_kinds(ctx):
    """classify_critical_point names minimum, maximum, saddle (also with a zero eigenvalue) and degenerate points"""
    rng = ctx.rng

    def spread(k, low=0.5, high=5.0):
        return list(rng.uniform(low, high, k))

    plan = [("minimum", spread(3), "list"), ("maximum", [-v for v in spread(3)], "array"),
            ("saddle", [*spread(2), -spread(1)[0]], "tuple"), ("saddle", [spread(1)[0], -spread(1)[0]], "array"),
            ("degenerate", [*spread(2), 0.0], "list"), ("degenerate", [-spread(1)[0], 0.0, -spread(1)[0]], "array"),
            ("saddle", [spread(1)[0], 0.0, -spread(1)[0]], "tuple"), ("minimum", spread(2, 0.01, 0.1), "list"),
            ("maximum", [-v for v in spread(2, 20.0, 50.0)], "array")]
    cases = [(eig, with_eigenvalues(rng, eig)) for _, eig, _ in plan]
    expected = [REF.classify_critical_point(m) for _, m in cases]
    slips = [_classify_slips(m) for _, m in cases]
    got = yield [call("classify_critical_point", Array(m.tolist())) for _, m in cases]
    return all_of([expect_text(g, kind, label=_classify_label(m, eig), mistakes=s)
                   for g, kind, s, (eig, m) in zip(got, expected, slips, cases)])


@CHECKS.check("classify_critical_point", points=1)
def classify_zero_threshold(ctx):
    """an eigenvalue counts as zero when its size <= 1e-8 max(1, largest size): 8e-9 next to 0.5, 5e-6 next to 1000"""
    rng = ctx.rng
    plan = [("degenerate", [0.5, 8e-9]), ("minimum", [0.5, 3e-8]), ("maximum", [-0.5, -3e-8]),
            ("degenerate", [-0.5, -8e-9, -0.3]), ("degenerate", [1e3, 5e-6]), ("minimum", [1e3, 3e-5]),
            ("degenerate", [1e3, -5e-6, 2.0]), ("saddle", [1e3, -3e-5])]
    cases = [(eig, with_eigenvalues(rng, eig)) for _, eig in plan]
    expected = [REF.classify_critical_point(m) for _, m in cases]
    slips = [_classify_slips(m) for _, m in cases]
    got = yield [call("classify_critical_point", Array(m.tolist())) for _, m in cases]
    return all_of([expect_text(g, kind, label=_classify_label(m, eig), mistakes=s)
                   for g, kind, s, (eig, m) in zip(got, expected, slips, cases)])


@CHECKS.check("classify_critical_point", points=1)
def classify_symmetrises_its_input(ctx):
    """classify_critical_point reads a non-symmetric matrix by its symmetric part (A + A^T)/2"""
    rng = ctx.rng
    skew = rng.uniform(-2, 2, (3, 3))
    skew = skew - skew.T
    symmetric = with_eigenvalues(rng, [2.0, 0.0, 1.0])
    cases = [("saddle", np.array([[1.0, 4.0], [0.0, 1.0]])),  # symmetric part [[1, 2], [2, 1]]: eigenvalues 3, -1
             ("minimum", np.array([[2.0, 3.0], [-3.0, 2.0]])),  # symmetric part 2 I
             ("maximum", np.array([[-1.0, 2.0], [-2.0, -1.0]])),  # symmetric part -I
             ("degenerate", symmetric + skew)]
    expected = [REF.classify_critical_point(m) for _, m in cases]
    slips = [_classify_slips(m) for _, m in cases]
    got = yield [call("classify_critical_point", Array(m.tolist())) for _, m in cases]
    verdicts = []
    for g, kind, s, (_, m) in zip(got, expected, slips, cases):
        sym = 0.5 * (m + m.T)
        v = expect_text(g, kind, label=_classify_label(m), mistakes=s)
        if not v.passed and g.ok:
            v.message += (f"\n  (the symmetric part (A + A^T)/2 = {_mat(sym)} has eigenvalues "
                          f"{', '.join(f'{e:.3g}' for e in np.linalg.eigvalsh(sym))})")
        verdicts.append(v)
    return all_of(verdicts)
