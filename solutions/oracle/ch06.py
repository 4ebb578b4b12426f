"""Chapter 6's expected values beyond the reference solution: what the usual bearing slips give."""

from __future__ import annotations

import numpy as np

from solutions.ch06_measurement import range_bearing


def bearing_mistakes(x, y) -> dict:
    """range_bearing with atan(y/x) for atan2, measured from the drone to the dish, or in degrees."""
    right = range_bearing(x, y)
    slips = {"atan": np.arctan(y / x) if x != 0 else np.nan, "reversed bearing": np.arctan2(-y, -x),
             "degrees": np.degrees(right[1])}
    return {name: np.array([right[0], bearing]) for name, bearing in slips.items()}
