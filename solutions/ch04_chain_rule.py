"""Chapter 4: the chain rule in matrix form, J_{g o f}(x) = Jg(f(x)) Jf(x)."""

from __future__ import annotations

import numpy as np

from .ch03_jacobian import polar_to_cartesian, polar_to_cartesian_jacobian


def g_stage(u) -> np.ndarray:
    """(u1^2 + u2, u1 u2)."""
    u1, u2 = np.asarray(u, dtype=float)
    return np.array([u1**2 + u2, u1 * u2])


def g_jacobian(u) -> np.ndarray:
    """[[2 u1, 1], [u2, u1]]."""
    u1, u2 = np.asarray(u, dtype=float)
    return np.array([[2 * u1, 1.0], [u2, u1]])


def compose_jacobian(f, jac_f, jac_g, x) -> np.ndarray:
    """Jg(f(x)) @ Jf(x)."""
    x = np.asarray(x, dtype=float)
    return np.asarray(jac_g(f(x)), dtype=float) @ np.asarray(jac_f(x), dtype=float)


def pipeline_jacobian(r, theta) -> np.ndarray:
    """Jacobian of g_stage(polar_to_cartesian(r, theta)) with respect to (r, theta)."""
    return compose_jacobian(lambda v: polar_to_cartesian(*v),
                            lambda v: polar_to_cartesian_jacobian(*v), g_jacobian, [r, theta])
