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


def range_bearing_elevation(x, y, z) -> np.ndarray:
    """(sqrt(x^2 + y^2 + z^2), atan2(y, x), atan2(z, sqrt(x^2 + y^2)))."""
    x, y, z = float(x), float(y), float(z)
    ground = np.hypot(x, y)
    return np.array([np.hypot(ground, z), np.arctan2(y, x), np.arctan2(z, ground)])


def H3_jacobian(x, y, z) -> np.ndarray:
    """d(range, bearing, elevation) / d(x, y, z), 3 x 3; ValueError where x = y = 0."""
    x, y, z = float(x), float(y), float(z)
    rho2 = x * x + y * y
    if rho2 == 0:
        raise ValueError("the bearing is undefined where x = y = 0")
    rho = np.sqrt(rho2)
    r2 = rho2 + z * z
    r = np.sqrt(r2)
    return np.array([[x / r, y / r, z / r],
                     [-y / rho2, x / rho2, 0.0],
                     [-z * x / (r2 * rho), -z * y / (r2 * rho), rho / r2]])
