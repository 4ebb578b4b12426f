"""Chapter 2: gradients, tangent planes and contours."""

from __future__ import annotations

import numpy as np


def example_f(x, y) -> float:
    """f(x, y) = x^2 + x y."""
    return float(x) ** 2 + float(x) * float(y)


def example_gradient(x, y) -> np.ndarray:
    """grad f = (2x + y, x)."""
    x, y = float(x), float(y)
    return np.array([2 * x + y, x])


def tangent_plane(f, grad, a, x) -> float:
    """f(a) + grad(a) . (x - a), for f and grad of one vector."""
    a = np.asarray(a, dtype=float)
    x = np.asarray(x, dtype=float)
    return float(f(a) + np.dot(np.asarray(grad(a), dtype=float), x - a))


def bowl_gradient(x, y) -> np.ndarray:
    """Gradient of g = x^2 + 0.5 x y + y^2: (2x + 0.5y, 0.5x + 2y)."""
    x, y = float(x), float(y)
    return np.array([2 * x + 0.5 * y, 0.5 * x + 2 * y])


def contour_direction(x, y) -> np.ndarray:
    """Unit tangent to g's contour through (x, y): the gradient turned by 90 degrees."""
    gx, gy = bowl_gradient(x, y)
    norm = np.hypot(gx, gy)
    if norm == 0:
        raise ValueError("the contour direction is undefined where the gradient is zero (0, 0)")
    return np.array([-gy, gx]) / norm
