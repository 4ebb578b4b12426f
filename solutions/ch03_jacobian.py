"""Chapter 3: the Jacobian of polar -> Cartesian, J[i, j] = d f_i / d x_j."""

from __future__ import annotations

import numpy as np


def polar_to_cartesian(r, theta) -> np.ndarray:
    """(r cos theta, r sin theta)."""
    r, theta = float(r), float(theta)
    return np.array([r * np.cos(theta), r * np.sin(theta)])


def polar_to_cartesian_jacobian(r, theta) -> np.ndarray:
    """[[cos theta, -r sin theta], [sin theta, r cos theta]]."""
    r, theta = float(r), float(theta)
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -r * s], [s, r * c]])


def area_scale(r, theta) -> float:
    """Signed determinant of the polar Jacobian (= r)."""
    return float(np.linalg.det(polar_to_cartesian_jacobian(r, theta)))


def spherical_to_cartesian(r, azimuth, elevation) -> np.ndarray:
    """(r cos(el) cos(az), r cos(el) sin(az), r sin(el))."""
    r, az, el = float(r), float(azimuth), float(elevation)
    return np.array([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)])


def spherical_to_cartesian_jacobian(r, azimuth, elevation) -> np.ndarray:
    """d(x, y, z) / d(r, azimuth, elevation), 3 x 3."""
    r, az, el = float(r), float(azimuth), float(elevation)
    ca, sa, ce, se = np.cos(az), np.sin(az), np.cos(el), np.sin(el)
    return np.array([[ce * ca, -r * ce * sa, -r * se * ca],
                     [ce * sa, r * ce * ca, -r * se * sa],
                     [se, 0.0, r * ce]])


def volume_scale(r, azimuth, elevation) -> float:
    """Signed determinant of the spherical Jacobian (= r^2 cos(elevation))."""
    return float(np.linalg.det(spherical_to_cartesian_jacobian(r, azimuth, elevation)))
