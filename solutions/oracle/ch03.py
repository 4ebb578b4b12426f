"""Chapter 3's expected values beyond the reference solution: what the usual slips give."""

from __future__ import annotations

import numpy as np

from solutions.ch03_jacobian import polar_to_cartesian


def polar_in_degrees(r, theta) -> np.ndarray:
    """polar_to_cartesian of a learner who reads theta as degrees."""
    return polar_to_cartesian(r, np.radians(theta))


def _colatitude(r, azimuth, elevation) -> tuple[np.ndarray, np.ndarray]:
    """The map and its Jacobian of a learner who measures the elevation from the z-axis (a colatitude)."""
    r, az, el = float(r), float(azimuth), float(elevation)
    ca, sa, ce, se = np.cos(az), np.sin(az), np.cos(el), np.sin(el)
    point = np.array([r * se * ca, r * se * sa, r * ce])
    jacobian = np.array([[se * ca, -r * se * sa, r * ce * ca], [se * sa, r * se * ca, r * ce * sa], [ce, 0.0, -r * se]])
    return point, jacobian


def spherical_mistakes(r, azimuth, elevation) -> dict:
    """spherical_to_cartesian with the elevation from the z-axis, in degrees, or azimuth and elevation swapped."""
    from solutions.ch03_jacobian import spherical_to_cartesian

    return {"colatitude": _colatitude(r, azimuth, elevation)[0],
            "degrees": spherical_to_cartesian(r, np.radians(azimuth), np.radians(elevation)),
            "angles swapped": spherical_to_cartesian(r, elevation, azimuth)}


def spherical_jacobian_mistakes(r, azimuth, elevation) -> dict:
    """The spherical Jacobian without the factor r in the angle columns, without cos(elevation) in the azimuth
    column, or of the colatitude map."""
    from solutions.ch03_jacobian import spherical_to_cartesian_jacobian

    right = spherical_to_cartesian_jacobian(r, azimuth, elevation)
    missing_r = right.copy()
    missing_r[:, 1:] /= float(r)
    missing_cos = right.copy()
    missing_cos[:, 1] /= np.cos(float(elevation))
    return {"missing r": missing_r, "missing cos(elevation)": missing_cos,
            "colatitude": _colatitude(r, azimuth, elevation)[1]}


def volume_scale_mistakes(r, azimuth, elevation) -> dict:
    """det J with one factor r, without cos(elevation), or of the colatitude map."""
    r, el = float(r), float(elevation)
    return {"r for r^2": r * np.cos(el), "missing cos(elevation)": r * r,
            "colatitude": float(np.linalg.det(_colatitude(r, azimuth, el)[1]))}
