"""Chapter 1's expected values: the reference functions applied to catalogue callables by name."""

from __future__ import annotations

import numpy as np

from grader.catalogue import CALLABLES
from solutions.ch01_tangent_line import linearization_error, tangent_line, taylor_error_estimate


def tangent_of(f: str, fprime: str, a, x):
    return tangent_line(CALLABLES[f], CALLABLES[fprime], a, x)


def error_of(f: str, fprime: str, a, x):
    return linearization_error(CALLABLES[f], CALLABLES[fprime], a, x)


def estimate_of(fsecond: str, a, delta):
    return taylor_error_estimate(CALLABLES[fsecond], a, delta)


def tangent_mistakes_of(f: str, fprime: str, a, x) -> dict:
    """What the usual slips give: the slope taken at x instead of a."""
    xs = np.asarray(x, dtype=float)
    function, slope = CALLABLES[f], CALLABLES[fprime]
    value = function(a) + slope(xs) * (xs - a)
    return {"slope at x": float(value) if np.ndim(x) == 0 else value}


def signed_error_of(f: str, fprime: str, a, x):
    """f(x) - L(x) without the absolute value."""
    xs = np.asarray(x, dtype=float)
    value = CALLABLES[f](xs) - tangent_line(CALLABLES[f], CALLABLES[fprime], a, xs)
    return float(value) if np.ndim(x) == 0 else value
