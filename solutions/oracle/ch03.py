"""Chapter 3's expected values beyond the reference solution: what the usual slips give."""

from __future__ import annotations

import numpy as np

from solutions.ch03_jacobian import polar_to_cartesian


def polar_in_degrees(r, theta) -> np.ndarray:
    """polar_to_cartesian of a learner who reads theta as degrees."""
    return polar_to_cartesian(r, np.radians(theta))
