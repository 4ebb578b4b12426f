"""Chapter 9: choose your tool: finite-difference gradient and Hessian, and reading the Hessian.

gradient_fd is compared with the analytic gradient of catalogue functions (a quadratic, a bowl, a
3-D cubic and Rosenbrock) with the finite-difference tolerance 1e-6 + 1e-6 |g| of
grader/checks/derivatives.py: at h = 1e-5 truncation h^2/6 M3 and rounding eps M0/h stay below
2e-7 on the sampled domain (|x| <= 1.5 for Rosenbrock).

hessian_fd is the central difference of a central-difference gradient, both with step h, so
(derivation as in derivatives.py, applied twice): truncation h^2/6 from each level, h^2/3 M4 in
all (M4 bounds fourth derivatives: 0 for the quadratics and the cubic, 2400 for Rosenbrock), and
the gradient's rounding error eps (M0 + |x| M1)/h differenced once more over 2h, eps (M0 + |x| M1)/h^2
(M0: the size of f's terms, M1: of its gradient). The tolerance is twice the sum of both, with a
factor 4 on the rounding for the argument roundings: 2.3e-6 for x^2 + x y at (1, 2), up to 1.6e-3
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

from grader.catalogue import CALLABLES
from grader.checks.base import chapter_checks
from grader.checks.derivatives import FD_ATOL, FD_RTOL, planar_point, vector_form
from grader.compare import Entries, Verdict, all_of, expect, fail, fmt, fmt_array, passed, value_problem
from grader.wire import Array, Fn, call

CHECKS = chapter_checks("ch09")

EPS = float(np.finfo(float).eps)
NAMES = ("x", "y", "z")
CLASSES = ("minimum", "maximum", "saddle", "degenerate")


def _grad_entries(n: int) -> Entries:
    return Entries("gradient", rows=tuple(f"d f/d {v}" for v in NAMES[:n]))


def _hess_entries(n: int) -> Entries:
    return Entries("Hessian", rows=NAMES[:n], cols=NAMES[:n])


def rosenbrock_grad(p) -> np.ndarray:
    x, y = np.asarray(p, dtype=float)
    return np.array([-2 * (1 - x) - 400 * x * (y - x * x), 200 * (y - x * x)])


def rosenbrock_hessian(p) -> np.ndarray:
    x, y = np.asarray(p, dtype=float)
    return np.array([[2 - 400 * (y - x * x) + 800 * x * x, -400 * x], [-400 * x, 200.0]])


# catalogue f -> (gradient, Hessian, size of f's terms, bound on fourth derivatives)
FUNCTIONS = {
    "example_f_vec": (CALLABLES["example_grad_vec"], lambda p: np.array([[2.0, 1.0], [1.0, 0.0]]),
                      lambda x, y: x * x + abs(x * y), 0.0),
    "bowl_vec": (CALLABLES["bowl_grad_vec"], lambda p: np.array([[2.0, 0.5], [0.5, 2.0]]),
                 lambda x, y: x * x + 0.5 * abs(x * y) + y * y, 0.0),
    "saddle3_vec": (CALLABLES["saddle3_grad_vec"],
                    lambda p: np.array([[2.0, 0.0, 3.0], [0.0, -2.0, -1.0], [3.0, -1.0, 6 * float(p[2])]]),
                    lambda x, y, z: x * x + y * y + 3 * abs(x * z) + abs(z) ** 3 + abs(y * z), 0.0),
    "rosenbrock_vec": (rosenbrock_grad, rosenbrock_hessian,
                       lambda x, y: (1 - x) ** 2 + 100 * (abs(y) + x * x) ** 2, 2400.0),
}


def hessian_tolerance(name: str, point: np.ndarray, h: float) -> float:
    """Twice the truncation h^2/3 M4 plus rounding 4 eps (M0 + (|x| + 2h) M1) / h^2 (M0, M1 over the box x +- 2h)."""
    grad, _, size, m4 = FUNCTIONS[name]
    box = [np.zeros_like(point)] + [2 * h * (2 * np.array(s, dtype=float) - 1) for s in np.ndindex(*(2,) * point.size)]
    m0 = max(float(size(*(point + d))) for d in box)
    m1 = max(float(np.sum(np.abs(grad(point + d)))) for d in box)
    reach = float(np.max(np.abs(point))) + 2 * h
    return 2 * (h * h / 3 * m4 + 4 * EPS * (m0 + reach * m1) / (h * h))


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

@CHECKS.check("gradient_fd", points=2)
def gradient_fd_random_points(ctx):
    """gradient_fd matches the analytic gradient of four functions (2-D and 3-D) at random points, given h or not"""
    rng = ctx.rng
    plan = [("example_f_vec", "tuple", None), ("bowl_vec", "list", None), ("saddle3_vec", "array", None),
            ("rosenbrock_vec", "list", None), ("saddle3_vec", "tuple", 1e-4), ("rosenbrock_vec", "array", "h=1e-6"),
            ("example_f_vec", "array", None)]
    cases = [(name, _point(rng, name), form, h) for name, form, h in plan]
    calls = []
    for name, p, form, h in cases:
        args = (Fn(name), vector_form(p, form))
        calls.append(call("gradient_fd", *args) if h is None else
                     call("gradient_fd", *args, h=1e-6) if isinstance(h, str) else call("gradient_fd", *args, h))
    got = yield calls
    verdicts = []
    for g, (name, p, form, h) in zip(got, cases):
        step = "" if h is None else (", h=1e-6" if isinstance(h, str) else f", {fmt(h)}")
        verdicts.append(expect(g, FUNCTIONS[name][0](p), label=f"gradient_fd({name}, {_show(p)}{step})",
                               rtol=FD_RTOL, atol=FD_ATOL, entries=_grad_entries(p.size)))
    return all_of(verdicts)


@CHECKS.check("gradient_fd", points=1)
def gradient_fd_integer_input(ctx):
    """gradient_fd converts integer x to float first: x^2 + x y at [1, 2], (1, 2) and np.array([1, 2]) gives (4, 1)"""
    got = yield [call("gradient_fd", Fn("example_f_vec"), Array([1, 2], "int64")),
                 call("gradient_fd", Fn("example_f_vec"), [1, 2]),
                 call("gradient_fd", Fn("example_f_vec"), (1, 2)),
                 call("gradient_fd", Fn("saddle3_vec"), Array([1, -2, 1], "int64"))]
    labels = ("gradient_fd(x^2 + x y, np.array([1, 2]) of int64)", "gradient_fd(x^2 + x y, [1, 2])",
              "gradient_fd(x^2 + x y, (1, 2))", "gradient_fd(saddle3_vec, np.array([1, -2, 1]) of int64)")
    expected = ([4.0, 1.0], [4.0, 1.0], [4.0, 1.0], CALLABLES["saddle3_grad_vec"]([1, -2, 1]))
    verdicts = []
    for g, want, label in zip(got, expected, labels):
        v = expect(g, want, label=label, rtol=FD_RTOL, atol=FD_ATOL, entries=_grad_entries(len(want)))
        if not v.passed and v.got is not None and np.shape(v.got) == np.shape(want) and not np.any(v.got):
            v.message += "\n  (all zeros: an integer array cannot hold x + h; convert x to float first)"
        verdicts.append(v)
    return all_of(verdicts)


# ------------------------------------------------------------------------------ hessian_fd

def _hessian_verdict(returned, name: str, p: np.ndarray, h: float, label: str) -> Verdict:
    tol = hessian_tolerance(name, p, h)
    return expect(returned, FUNCTIONS[name][1](p), label=label, rtol=0.0, atol=tol, entries=_hess_entries(p.size))


@CHECKS.check("hessian_fd", points=1)
def hessian_fd_worked_example(ctx):
    """hessian_fd of x^2 + x y at (1, 2) is [[2, 1], [1, 0]]"""
    got = yield call("hessian_fd", Fn("example_f_vec"), (1, 2))
    return _hessian_verdict(got, "example_f_vec", np.array([1.0, 2.0]), 1e-4, "hessian_fd(x^2 + x y, (1, 2))")


@CHECKS.check("hessian_fd", points=2)
def hessian_fd_random_points(ctx):
    """hessian_fd matches the analytic Hessian of a bowl, a 3-D cubic and Rosenbrock at random points, given h or not"""
    rng = ctx.rng
    plan = [("saddle3_vec", "tuple", None), ("rosenbrock_vec", "list", None), ("bowl_vec", "array", None),
            ("saddle3_vec", "array", 1e-3), ("rosenbrock_vec", "tuple", "h=1e-3"), ("saddle3_vec", "list", None)]
    cases = [(name, _point(rng, name), form, h) for name, form, h in plan]
    calls = []
    for name, p, form, h in cases:
        args = (Fn(name), vector_form(p, form))
        calls.append(call("hessian_fd", *args) if h is None else
                     call("hessian_fd", *args, h=1e-3) if isinstance(h, str) else call("hessian_fd", *args, h))
    got = yield calls
    verdicts = []
    for g, (name, p, form, h) in zip(got, cases):
        step = 1e-4 if h is None else 1e-3
        shown = "" if h is None else (", h=1e-3" if isinstance(h, str) else ", 0.001")
        verdicts.append(_hessian_verdict(g, name, p, step, f"hessian_fd({name}, {_show(p)}{shown})"))
    return all_of(verdicts)


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
            return fail(f"{label} is not exactly symmetric: Hessian[{i},{j}] = {float(out[i, j])!r} but Hessian[{j},{i}] = "
                        f"{float(out[j, i])!r}. A finite-difference Jacobian of the gradient is only nearly symmetric: "
                        "return (J + J^T) / 2.", got=out)
    return passed()


# ------------------------------------------------------------------------------ classify_critical_point

def expect_text(returned, expected: str, *, label: str) -> Verdict:
    """The call must return exactly the string `expected`."""
    if not returned.ok:
        return fail(returned.problem(), expected=expected)
    enc = returned.encoded
    if enc["t"] != "str":
        shown = fmt_array(returned.as_array()) if returned.as_array() is not None else returned.type_name
        return fail(f"{label} returned {shown}; expected the string {expected!r}.", expected=expected)
    text = enc["text"]
    if text == expected:
        return passed(expected=expected, got=text)
    hint = ""
    if text.strip().lower() == expected:
        hint = " (exactly, in lower case and without spaces)"
    elif text not in CLASSES:
        hint = f" (the answer is one of {', '.join(repr(c) for c in CLASSES)})"
    return fail(f"{label} returned {text!r}; expected {expected!r}{hint}.", expected=expected, got=text)


def with_eigenvalues(rng: np.random.Generator, eigenvalues) -> np.ndarray:
    """Q diag(eigenvalues) Q^T for a random rotation Q: symmetric, non-diagonal, these eigenvalues."""
    n = len(eigenvalues)
    q, r = np.linalg.qr(rng.standard_normal((n, n)))
    q = q * np.sign(np.diag(r))
    m = q @ np.diag(eigenvalues) @ q.T
    return 0.5 * (m + m.T)


def _matrix_form(m: np.ndarray, form: str):
    if form == "tuple":
        return tuple(tuple(float(v) for v in row) for row in m)
    return m.tolist() if form == "list" else Array(m.tolist())


def _classify_label(m: np.ndarray, eigenvalues=None) -> str:
    text = f"classify_critical_point({_mat(m)})"
    return text if eigenvalues is None else f"{text} (eigenvalues {', '.join(f'{v:.3g}' for v in eigenvalues)})"


@CHECKS.check("classify_critical_point", points=1)
def classify_worked_example(ctx):
    """classify_critical_point([[2, 1], [1, 0]]) is "saddle" (the Hessian of x^2 + x y)"""
    got = yield call("classify_critical_point", [[2, 1], [1, 0]])
    return expect_text(got, "saddle", label="classify_critical_point([[2, 1], [1, 0]])")


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
    cases = [(kind, eig, with_eigenvalues(rng, eig), form) for kind, eig, form in plan]
    got = yield [call("classify_critical_point", _matrix_form(m, form)) for _, _, m, form in cases]
    return all_of([expect_text(g, kind, label=_classify_label(m, eig)) for g, (kind, eig, m, _) in zip(got, cases)])


@CHECKS.check("classify_critical_point", points=1)
def classify_zero_threshold(ctx):
    """an eigenvalue counts as zero when its size <= 1e-8 max(1, largest size): 8e-9 next to 0.5, 5e-6 next to 1000"""
    rng = ctx.rng
    plan = [("degenerate", [0.5, 8e-9]), ("minimum", [0.5, 3e-8]), ("maximum", [-0.5, -3e-8]),
            ("degenerate", [-0.5, -8e-9, -0.3]), ("degenerate", [1e3, 5e-6]), ("minimum", [1e3, 3e-5]),
            ("degenerate", [1e3, -5e-6, 2.0]), ("saddle", [1e3, -3e-5])]
    cases = [(kind, eig, with_eigenvalues(rng, eig)) for kind, eig in plan]
    got = yield [call("classify_critical_point", Array(m.tolist())) for _, _, m in cases]
    return all_of([expect_text(g, kind, label=_classify_label(m, eig)) for g, (kind, eig, m) in zip(got, cases)])


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
    got = yield [call("classify_critical_point", m.tolist()) for _, m in cases]
    verdicts = []
    for g, (kind, m) in zip(got, cases):
        sym = 0.5 * (m + m.T)
        v = expect_text(g, kind, label=_classify_label(m))
        if not v.passed and g.ok:
            v.message += (f"\n  (the symmetric part (A + A^T)/2 = {_mat(sym)} has eigenvalues "
                          f"{', '.join(f'{e:.3g}' for e in np.linalg.eigvalsh(sym))})")
        verdicts.append(v)
    return all_of(verdicts)
