"""Chapter 0's expected values beyond the reference solution: the exact law of the noisy range."""

from __future__ import annotations

import numpy as np


def rice_moments(r: float, sigma: float) -> tuple[float, float]:
    """E[R] and Var[R] for R = |m + sigma Z|, Z standard normal in 2-D, |m| = r.

    E[R] = sigma sqrt(pi/2) e^-t ((1 + 2t) I0(t) + 2t I1(t)) with t = r^2 / (4 sigma^2); the scaled
    Bessel functions e^-t I_k(t) = (1/pi) int_0^pi e^(t (cos u - 1)) cos(k u) du are integrated by
    the trapezoid rule, exact to rounding for this smooth periodic integrand.
    """
    t = r * r / (4 * sigma * sigma)
    u = np.linspace(0.0, np.pi, 4001)
    weights = np.full(u.size, 1.0 / (u.size - 1))
    weights[[0, -1]] *= 0.5
    base = np.exp(t * (np.cos(u) - 1.0))
    i0, i1 = float(weights @ base), float(weights @ (base * np.cos(u)))
    mean = sigma * np.sqrt(np.pi / 2) * ((1 + 2 * t) * i0 + 2 * t * i1)
    return float(mean), float(2 * sigma * sigma + r * r - mean * mean)


def shift_law(mean, sigma: float) -> tuple[float, float, float, float]:
    """(the exact mean shift E[R] - r, the standard deviation of one range reading R, sigma^2 / 2r, r)."""
    r = float(np.hypot(*np.asarray(mean, dtype=float)))
    expected_range, variance = rice_moments(r, sigma)
    return expected_range - r, float(np.sqrt(variance)), sigma * sigma / (2 * r), r
