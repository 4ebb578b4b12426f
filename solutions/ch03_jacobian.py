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
