"""Chapter 7's expected values beyond the reference solution: the arc motion model (the usual slip for
the lesson's Euler step)."""

from __future__ import annotations

import numpy as np


def arc_motion(state, v, omega, dt) -> np.ndarray:
    """The exact constant-turn-rate motion instead of the lesson's Euler step."""
    x, y, th = np.asarray(state, dtype=float)
    return np.array([x + v / omega * (np.sin(th + omega * dt) - np.sin(th)),
                     y - v / omega * (np.cos(th + omega * dt) - np.cos(th)), th + omega * dt])
