"""Chapter 9: choose your tool: gradient, Jacobian, Hessian, finite difference."""

from __future__ import annotations

import numpy as np

from .ch05_finite_differences import jacobian_fd


def gradient_fd(f, x, h=1e-5) -> np.ndarray:
    """Central-difference gradient of a scalar f of a vector x."""
    x = np.asarray(x, dtype=float)
    grad = np.empty(x.size)
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h
        grad[j] = (float(f(x + e)) - float(f(x - e))) / (2 * h)
    return grad


def hessian_fd(f, x, h=1e-4) -> np.ndarray:
    """n x n Hessian as the Jacobian of the gradient, symmetrised."""
    H = jacobian_fd(lambda v: gradient_fd(f, v, h), x, h)
    return 0.5 * (H + H.T)


def classify_critical_point(hessian) -> str:
    """'saddle', 'minimum', 'maximum' or 'degenerate' from the Hessian's eigenvalues."""
    A = np.asarray(hessian, dtype=float)
    A = 0.5 * (A + A.T)
    eigenvalues = np.linalg.eigvalsh(A)
    tolerance = 1e-8 * max(1.0, float(np.max(np.abs(eigenvalues))))
    positive = bool(np.any(eigenvalues > tolerance))
    negative = bool(np.any(eigenvalues < -tolerance))
    if positive and negative:
        return "saddle"
    if np.any(np.abs(eigenvalues) <= tolerance):
        return "degenerate"
    return "minimum" if positive else "maximum"
