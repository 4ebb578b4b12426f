"""Chapter 6: the range-bearing measurement and its Jacobian H."""

from __future__ import annotations

import numpy as np


def range_bearing(x, y) -> np.ndarray:
    """(sqrt(x^2 + y^2), atan2(y, x))."""
    x, y = float(x), float(y)
    return np.array([np.hypot(x, y), np.arctan2(y, x)])


def H_jacobian(x, y) -> np.ndarray:
    """[[x/r, y/r], [-y/r^2, x/r^2]]; ValueError at r = 0."""
    x, y = float(x), float(y)
    r2 = x * x + y * y
    if r2 == 0:
        raise ValueError("H is undefined at r = 0")
    r = np.sqrt(r2)
    return np.array([[x / r, y / r], [-y / r2, x / r2]])


def measurement_covariance(x, y, sigma) -> np.ndarray:
    """H (sigma^2 I) H^T = sigma^2 diag(1, 1/r^2); ValueError at r = 0."""
    H = H_jacobian(x, y)
    return float(sigma) ** 2 * (H @ H.T)
