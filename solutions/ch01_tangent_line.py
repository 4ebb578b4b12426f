"""Chapter 1: the tangent line L(x) = f(a) + f'(a)(x - a) and how fast it peels away."""

from __future__ import annotations

import numpy as np


def _out(value, x):
    return float(value) if np.ndim(x) == 0 else np.asarray(value, dtype=float)


def tangent_line(f, fprime, a, x):
    """L(x) = f(a) + f'(a) (x - a); x a float or an array."""
    xs = np.asarray(x, dtype=float)
    return _out(f(a) + fprime(a) * (xs - a), x)


def linearization_error(f, fprime, a, x):
    """|f(x) - L(x)|; x a float or an array."""
    xs = np.asarray(x, dtype=float)
    return _out(np.abs(f(xs) - (f(a) + fprime(a) * (xs - a))), x)


def taylor_error_estimate(fsecond, a, delta):
    """0.5 |f''(a)| delta^2: the leading term of the tangent line's error."""
    return _out(0.5 * np.abs(fsecond(a)) * np.asarray(delta, dtype=float) ** 2, delta)
