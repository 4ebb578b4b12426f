"""Chapter 2's expected values: the reference tangent plane of catalogue functions, by name."""

from __future__ import annotations

import numpy as np

from grader.catalogue import CALLABLES
from solutions.ch02_gradient import tangent_plane


def tangent_plane_of(f: str, grad: str, a, x) -> float:
    return tangent_plane(CALLABLES[f], CALLABLES[grad], a, x)


def tangent_plane_mistakes_of(f: str, grad: str, a, x) -> dict:
    """What the usual slips give: the gradient taken at x instead of a."""
    a, x = np.asarray(a, dtype=float), np.asarray(x, dtype=float)
    return {"gradient at x": float(CALLABLES[f](a) + np.dot(CALLABLES[grad](x), x - a))}


def planner_cost_mistakes(x, y, obstacle) -> dict:
    """planner_cost with the obstacle term 1/d instead of 1/d^2, or without the lane term."""
    from solutions.ch02_gradient import _obstacle_offset

    _, _, d2 = _obstacle_offset(x, y, obstacle)
    return {"1/d for 1/d^2": float(y) ** 2 + 1.0 / np.sqrt(d2), "missing lane term": 1.0 / d2}


def planner_gradient_mistakes(x, y, obstacle) -> dict:
    """What the usual slips in differentiating planner_cost give."""
    from solutions.ch02_gradient import _obstacle_offset

    dx, dy, d2 = _obstacle_offset(x, y, obstacle)
    lane = np.array([0.0, 2.0 * float(y)])
    offset = np.array([dx, dy])
    return {"d^2 for d^4": lane - 2.0 * offset / d2, "obstacle term sign": lane + 2.0 * offset / d2**2,
            "missing 2": lane - offset / d2**2, "missing lane term": -2.0 * offset / d2**2}
