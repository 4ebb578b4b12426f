"""Chapter 8's expected values beyond the reference solution: raw bearings (what a missing unwrap
gives), the spread of the mismatch statistic, and the measurements the EKF checks feed in."""

from __future__ import annotations

import functools

import numpy as np

from solutions.ch06_measurement import range_bearing
from solutions.ch08_lab import linearized_measurement_cov

SIMULATED_CLOUDS = 20


def raw_bearings(samples) -> np.ndarray:
    """atan2 of every sample, not unwrapped."""
    samples = np.asarray(samples, dtype=float)
    return np.arctan2(samples[:, 1], samples[:, 0])


@functools.lru_cache(maxsize=64)
def mismatch_distribution(x: float, y: float, sigma: float, n: int,
                          clouds: int = SIMULATED_CLOUDS) -> tuple[float, float]:
    """Mean and standard deviation of the mismatch statistic over simulated clouds of n samples
    (seeded from the case itself and cached, so a batch pays for each case once)."""
    rng = np.random.default_rng([int(abs(v) * 1e6) for v in (x, y, sigma)] + [n, clouds])
    points = np.array([x, y]) + sigma * rng.standard_normal((clouds, n, 2))
    bearings = np.arctan2(points[..., 1], points[..., 0])
    ref_bearing = np.arctan2(y, x)
    bearings = bearings + 2 * np.pi * np.round((ref_bearing - bearings) / (2 * np.pi))
    z = np.stack([np.hypot(points[..., 0], points[..., 1]), bearings], axis=-1)
    centred = z - z.mean(axis=1, keepdims=True)
    s_mc = centred.transpose(0, 2, 1) @ centred / (n - 1)
    s_lin = linearized_measurement_cov(x, y, sigma)
    values = np.linalg.norm(s_mc - s_lin, axis=(1, 2)) / np.linalg.norm(s_lin)
    return float(values.mean()), float(values.std(ddof=1))


def cloud(mean, sigma: float, n: int, seed: int) -> np.ndarray:
    """The reference's n samples of N(mean, sigma^2 I) from np.random.default_rng(seed) (for the report)."""
    from solutions.ch08_lab import sample_positions

    return sample_positions(mean, sigma, n, np.random.default_rng(seed))


def ekf_mistakes(x, P, z, R) -> dict:
    """(x_new, P_new) of the usual EKF slips: the bearing innovation not wrapped or wrapped into [0, 2 pi), R left
    out of S or squared in it (a variance taken for a standard deviation)."""
    from solutions.ch06_measurement import H_jacobian

    x, P, z, R = (np.asarray(a, dtype=float) for a in (x, P, z, R))
    H = H_jacobian(x[0], x[1])

    def update(innovation, S):
        K = np.linalg.solve(S, H @ P).T
        I_KH = np.eye(2) - K @ H
        return x + K @ innovation, I_KH @ P @ I_KH.T + K @ R @ K.T

    raw = z - range_bearing(x[0], x[1])
    wrapped = raw.copy()
    wrapped[1] = (wrapped[1] + np.pi) % (2 * np.pi) - np.pi
    one_turn = raw.copy()
    one_turn[1] = one_turn[1] % (2 * np.pi)
    K_no_R = np.linalg.solve(H @ P @ H.T, H @ P).T
    return {"innovation not wrapped": update(raw, H @ P @ H.T + R),
            "innovation wrapped into [0, 2 pi)": update(one_turn, H @ P @ H.T + R),
            "R missing": (x + K_no_R @ wrapped, (np.eye(2) - K_no_R @ H) @ P),
            "R as a standard deviation": update(wrapped, H @ P @ H.T + R @ R)}


__all__ = ["cloud", "ekf_mistakes", "mismatch_distribution", "range_bearing", "raw_bearings"]
