"""Chapter 0: the range sensor is not linear, so no fixed matrix H gives range = H [x, y]."""

from __future__ import annotations

import numpy as np


def range_reading(x, y) -> float:
    """Distance from the dish at the origin to (x, y): sqrt(x^2 + y^2)."""
    return float(np.hypot(float(x), float(y)))


def superposition_gap(p, q) -> float:
    """range(p + q) - (range(p) + range(q)); nonzero shows the sensor is not linear."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    s = p + q
    return range_reading(s[0], s[1]) - (range_reading(p[0], p[1]) + range_reading(q[0], q[1]))


def mean_shift(mean, sigma, n, seed) -> float:
    """Mean range of n samples of N(mean, sigma^2 I) minus the range of the mean."""
    mean = np.asarray(mean, dtype=float)
    rng = np.random.default_rng(seed)
    samples = mean + sigma * rng.standard_normal((int(n), 2))
    return float(np.mean(np.hypot(samples[:, 0], samples[:, 1])) - range_reading(mean[0], mean[1]))
