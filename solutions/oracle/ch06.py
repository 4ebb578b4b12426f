"""Chapter 6's expected values beyond the reference solution: what the usual bearing slips give."""

from __future__ import annotations

import numpy as np

from solutions.ch06_measurement import range_bearing


def bearing_mistakes(x, y) -> dict:
    """range_bearing with atan(y/x) for atan2 (or atan(y/x) + pi everywhere), measured from the drone to the dish,
    or in degrees."""
    right = range_bearing(x, y)
    slips = {"atan": np.arctan(y / x) if x != 0 else np.nan, "reversed bearing": np.arctan2(-y, -x),
             "degrees": np.degrees(right[1]), "atan plus pi": np.arctan(y / x) + np.pi if x != 0 else np.nan}
    return {name: np.array([right[0], bearing]) for name, bearing in slips.items()}


def elevation_mistakes(x, y, z) -> dict:
    """range_bearing_elevation with the elevation from the z-axis, the range without z, atan for the bearing,
    or the angles in degrees."""
    from solutions.ch06_measurement import range_bearing_elevation

    right = range_bearing_elevation(x, y, z)
    ground = float(np.hypot(x, y))
    slips = {"colatitude": [right[0], right[1], np.arctan2(ground, z)],
             "elevation over the 3-D range": [right[0], right[1], np.arctan2(z, right[0])],
             "range without z": [ground, right[1], right[2]],
             "atan": [right[0], np.arctan(y / x) if x != 0 else np.nan, right[2]],
             "degrees": [right[0], np.degrees(right[1]), np.degrees(right[2])]}
    return {name: np.array(value, dtype=float) for name, value in slips.items()}


def H3_mistakes(x, y, z) -> dict:
    """What the usual slips in differentiating range_bearing_elevation give."""
    from solutions.ch06_measurement import H3_jacobian

    right = H3_jacobian(x, y, z)
    r2, rho2 = float(x * x + y * y + z * z), float(x * x + y * y)
    elevation_sign, bearing_over_r2, elevation_over_rho2 = right.copy(), right.copy(), right.copy()
    elevation_sign[2, :2] = -elevation_sign[2, :2]
    bearing_over_r2[1] = right[1] * rho2 / r2
    elevation_over_rho2[2] = right[2] * r2 / rho2
    return {"elevation row sign": elevation_sign, "bearing over r^2": bearing_over_r2,
            "elevation over rho^2": elevation_over_rho2}
