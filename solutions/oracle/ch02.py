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
