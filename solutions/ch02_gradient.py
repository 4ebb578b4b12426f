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


def _obstacle_offset(x, y, obstacle) -> tuple[float, float, float]:
    """(x - ox, y - oy, their squared length); ValueError at the obstacle."""
    ox, oy = np.asarray(obstacle, dtype=float)
    dx, dy = float(x) - ox, float(y) - oy
    d2 = dx * dx + dy * dy
    if d2 == 0:
        raise ValueError("the planner's cost is undefined at the obstacle")
    return dx, dy, d2


def planner_cost(x, y, obstacle) -> float:
    """y^2 + 1 / |(x, y) - obstacle|^2: the lane centre on y = 0 and an obstacle to keep away from."""
    _, _, d2 = _obstacle_offset(x, y, obstacle)
    return float(y) ** 2 + 1.0 / d2


def planner_cost_gradient(x, y, obstacle) -> np.ndarray:
    """Gradient of planner_cost with respect to (x, y)."""
    dx, dy, d2 = _obstacle_offset(x, y, obstacle)
    push = -2.0 / (d2 * d2)
    return np.array([push * dx, 2.0 * float(y) + push * dy])
