"""Chapter 5: numerical vs analytic derivatives (finite differences and the Jacobian check)."""

from __future__ import annotations

import numpy as np


def forward_difference(f, x, h) -> float:
    """(f(x + h) - f(x)) / h."""
    return float((f(x + h) - f(x)) / h)


def central_difference(f, x, h) -> float:
    """(f(x + h) - f(x - h)) / (2 h)."""
    return float((f(x + h) - f(x - h)) / (2 * h))


def jacobian_fd(f, x, h=1e-5) -> np.ndarray:
    """m x n central-difference Jacobian of a vector function f of one vector x."""
    x = np.asarray(x, dtype=float)
    columns = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h
        plus = np.atleast_1d(np.asarray(f(x + e), dtype=float))
        minus = np.atleast_1d(np.asarray(f(x - e), dtype=float))
        columns.append((plus - minus) / (2 * h))
    return np.stack(columns, axis=1)


def max_jacobian_error(jac, f, x, h=1e-5) -> float:
    """max |jac(x) - jacobian_fd(f, x, h)|: the Jacobian check."""
    analytic = np.asarray(jac(np.asarray(x, dtype=float)), dtype=float)
    numeric = jacobian_fd(f, x, h)
    return float(np.max(np.abs(analytic.reshape(numeric.shape) - numeric)))


def best_step(f, fprime, x, hs) -> float:
    """The h in hs whose central-difference error against fprime(x) is smallest."""
    errors = [abs(central_difference(f, x, h) - fprime(x)) for h in hs]
    return float(list(hs)[int(np.argmin(errors))])
