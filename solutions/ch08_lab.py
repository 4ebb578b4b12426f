"""Chapter 8: linearization lab, Monte Carlo cloud vs linearized ellipse, and an EKF update."""

from __future__ import annotations

import numpy as np

from .ch06_measurement import H_jacobian, range_bearing


def sample_positions(mean, sigma, n, rng) -> np.ndarray:
    """n x 2 samples of N(mean, sigma^2 I) drawn from the Generator rng."""
    return np.asarray(mean, dtype=float) + sigma * rng.standard_normal((int(n), 2))


def measure_samples(samples, ref_bearing) -> np.ndarray:
    """n x 2 (range, bearing), each bearing moved by whole turns to within pi of ref_bearing."""
    samples = np.asarray(samples, dtype=float)
    ranges = np.hypot(samples[:, 0], samples[:, 1])
    bearings = np.arctan2(samples[:, 1], samples[:, 0])
    bearings = bearings + 2 * np.pi * np.round((ref_bearing - bearings) / (2 * np.pi))
    return np.column_stack([ranges, bearings])


def linearized_measurement_cov(x, y, sigma) -> np.ndarray:
    """H Sigma H^T with Sigma = sigma^2 I, at the operating point (x, y)."""
    H = H_jacobian(x, y)
    return float(sigma) ** 2 * (H @ H.T)


def sample_covariance(z) -> np.ndarray:
    """Unbiased 2 x 2 sample covariance of an n x 2 array (n >= 2)."""
    z = np.asarray(z, dtype=float)
    centred = z - z.mean(axis=0)
    return centred.T @ centred / (z.shape[0] - 1)


def linearization_mismatch(x, y, sigma, n, seed) -> float:
    """norm(S_mc - S_lin) / norm(S_lin): sampled vs linearized measurement covariance."""
    rng = np.random.default_rng(seed)
    samples = sample_positions([x, y], sigma, n, rng)
    z = measure_samples(samples, np.arctan2(y, x))
    s_mc = sample_covariance(z)
    s_lin = linearized_measurement_cov(x, y, sigma)
    return float(np.linalg.norm(s_mc - s_lin) / np.linalg.norm(s_lin))


def ekf_update(x, P, z, R):
    """One EKF update of a 2-D position with a range-bearing measurement: (x_new, P_new)."""
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    z = np.asarray(z, dtype=float)
    R = np.asarray(R, dtype=float)
    H = H_jacobian(x[0], x[1])
    innovation = z - range_bearing(x[0], x[1])
    innovation[1] = (innovation[1] + np.pi) % (2 * np.pi) - np.pi
    S = H @ P @ H.T + R
    K = np.linalg.solve(S, H @ P).T  # P H^T S^-1, with S and P symmetric
    x_new = x + K @ innovation
    I_KH = np.eye(2) - K @ H
    P_new = I_KH @ P @ I_KH.T + K @ R @ K.T
    return x_new, P_new
