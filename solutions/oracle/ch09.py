"""Chapter 9's expected values: exact gradients and Hessians of the catalogue's functions of a
vector, the tolerance a right hessian_fd meets (derived in grader/checks/ch09.py), and the quiz's
gradient of x^2 + x y."""

from __future__ import annotations

import numpy as np

from grader.catalogue import CALLABLES
from solutions.ch09_choose_your_tool import classify_critical_point

EPS = float(np.finfo(float).eps)


def _rosenbrock_hessian(p) -> np.ndarray:
    x, y = np.asarray(p, dtype=float)
    return np.array([[2 - 400 * (y - x * x) + 800 * x * x, -400 * x], [-400 * x, 200.0]])


def _wave_hessian(p) -> np.ndarray:
    x, y = np.asarray(p, dtype=float)
    return np.array([[1 - y * np.sin(x), np.cos(x)], [np.cos(x), 0.0]])


def _twin_hessian(p) -> np.ndarray:
    dx, dy = np.asarray(p, dtype=float) - np.array([1.0, 2.0])
    return np.array([[2 * np.exp(dx), 1.0], [1.0, 6 * dy]])


# catalogue f -> (its gradient, its Hessian, size of f's terms, bound on fourth derivatives near the
# points drawn)
FUNCTIONS = {
    "wave_vec": (CALLABLES["wave_grad_vec"], _wave_hessian, lambda x, y: abs(y) + 0.5 * x * x, 5.0),
    "bowl_vec": (lambda p: np.array([2 * p[0] + 0.5 * p[1], 0.5 * p[0] + 2 * p[1]]),
                 lambda p: np.array([[2.0, 0.5], [0.5, 2.0]]), lambda x, y: x * x + 0.5 * abs(x * y) + y * y, 0.0),
    "saddle3_vec": (CALLABLES["saddle3_grad_vec"],
                    lambda p: np.array([[2.0, 0.0, 3.0], [0.0, -2.0, -1.0], [3.0, -1.0, 6 * float(p[2])]]),
                    lambda x, y, z: x * x + y * y + 3 * abs(x * z) + abs(z) ** 3 + abs(y * z), 0.0),
    "rosenbrock_vec": (CALLABLES["rosenbrock_grad_vec"], _rosenbrock_hessian,
                       lambda x, y: (1 - x) ** 2 + 100 * (abs(y) + x * x) ** 2, 2400.0),
    "hessian_twin_vec": (CALLABLES["hessian_twin_grad_vec"], _twin_hessian,
                         lambda x, y: 2 * np.exp(x - 1) + abs((x - 1) * (y - 2)) + abs(y - 2) ** 3, 2.1),
}


def gradient_of(name: str, point) -> np.ndarray:
    return np.asarray(FUNCTIONS[name][0](np.asarray(point, dtype=float)), dtype=float)


def hessian_of(name: str, point) -> np.ndarray:
    return np.asarray(FUNCTIONS[name][1](np.asarray(point, dtype=float)), dtype=float)


def hessian_tolerance(name: str, point, h: float) -> float:
    """Twice the truncation h^2/3 M4 plus rounding 4 eps (M0 + (|x| + 2h) M1) / h^2 (M0, M1 over the box x +- 2h)."""
    point = np.asarray(point, dtype=float)
    grad, _, size, m4 = FUNCTIONS[name]
    box = [np.zeros_like(point)] + [2 * h * (2 * np.array(s, dtype=float) - 1) for s in np.ndindex(*(2,) * point.size)]
    m0 = max(float(size(*(point + d))) for d in box)
    m1 = max(float(np.sum(np.abs(grad(point + d)))) for d in box)
    reach = float(np.max(np.abs(point))) + 2 * h
    return 2 * (h * h / 3 * m4 + 4 * EPS * (m0 + reach * m1) / (h * h))


def gradient_of_example_f(x, y) -> np.ndarray:
    """The gradient of f = x^2 + x y at (x, y), for the quiz's per-learner question."""
    return np.array([2.0 * x + y, float(x)])


def gradient_fd_of(name: str, point, h: float, form: str = "central") -> np.ndarray:
    """The difference-quotient gradient of catalogue function `name` as the contract's formula gives it
    ("central"), or as a forward difference does."""
    f = CALLABLES[name]
    point = np.asarray(point, dtype=float)
    out = np.zeros(point.size)
    for j in range(point.size):
        e = np.zeros_like(point)
        e[j] = h
        out[j] = ((f(point + e) - f(point)) / h if form == "forward"
                  else (f(point + e) - f(point - e)) / (2 * h))
    return out


def hessian_fd_of(name: str, point, h: float) -> np.ndarray:
    """The reference's hessian_fd of catalogue function `name` with step h, exactly as the contract's formula gives it."""
    from solutions.ch09_choose_your_tool import hessian_fd

    return hessian_fd(CALLABLES[name], np.asarray(point, dtype=float), h)


def _classified(eigenvalues, tolerance: float) -> str:
    positive, negative = bool(np.any(eigenvalues > tolerance)), bool(np.any(eigenvalues < -tolerance))
    if positive and negative:
        return "saddle"
    if np.any(np.abs(eigenvalues) <= tolerance):
        return "degenerate"
    return "minimum" if positive else "maximum"


def classify_mistakes(hessian) -> dict:
    """classify_critical_point's answer with a zero eigenvalue tested before both signs, with no tolerance
    (eigenvalues compared with 0 exactly), with an absolute 1e-8, or without symmetrising (np.linalg.eigvals of the
    matrix as given, real parts)."""
    A = np.asarray(hessian, dtype=float)
    symmetric = np.linalg.eigvalsh(0.5 * (A + A.T))
    as_given = np.real(np.linalg.eigvals(A))
    tolerance = 1e-8 * max(1.0, float(np.max(np.abs(symmetric))))
    zero_first = "degenerate" if np.any(np.abs(symmetric) <= tolerance) else _classified(symmetric, tolerance)
    return {"degenerate before saddle": zero_first,
            "no tolerance": _classified(symmetric, 0.0), "absolute tolerance": _classified(symmetric, 1e-8),
            "not symmetrised": _classified(as_given, 1e-8 * max(1.0, float(np.max(np.abs(as_given)))))}


__all__ = ["classify_critical_point", "classify_mistakes", "gradient_fd_of", "gradient_of", "gradient_of_example_f", "hessian_fd_of",
           "hessian_of", "hessian_tolerance"]
