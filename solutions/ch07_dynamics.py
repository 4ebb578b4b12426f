"""Chapter 7: the motion model, its Jacobian F and covariance propagation F P F^T + Q."""

from __future__ import annotations

import numpy as np


def motion_model(state, v, omega, dt) -> np.ndarray:
    """(x + v cos(th) dt, y + v sin(th) dt, th + omega dt)."""
    x, y, th = np.asarray(state, dtype=float)
    return np.array([x + v * np.cos(th) * dt, y + v * np.sin(th) * dt, th + omega * dt])


def F_jacobian(state, v, omega, dt) -> np.ndarray:
    """[[1, 0, -v sin(th) dt], [0, 1, v cos(th) dt], [0, 0, 1]]."""
    th = float(np.asarray(state, dtype=float)[2])
    return np.array([[1.0, 0.0, -v * np.sin(th) * dt], [0.0, 1.0, v * np.cos(th) * dt], [0.0, 0.0, 1.0]])


def propagate_covariance(P, F, Q=None) -> np.ndarray:
    """F P F^T, plus Q when given."""
    P = np.asarray(P, dtype=float)
    F = np.asarray(F, dtype=float)
    out = F @ P @ F.T
    if Q is not None:
        out = out + np.asarray(Q, dtype=float)
    return out


def bicycle_model(state, v, steer, wheelbase, dt) -> np.ndarray:
    """(x + v cos(th) dt, y + v sin(th) dt, th + v tan(steer) / wheelbase * dt)."""
    x, y, th = np.asarray(state, dtype=float)
    return np.array([x + v * np.cos(th) * dt, y + v * np.sin(th) * dt, th + v * np.tan(steer) / wheelbase * dt])


def bicycle_control_jacobian(state, v, steer, wheelbase, dt) -> np.ndarray:
    """d bicycle_model / d(v, steer), 3 x 2."""
    th = float(np.asarray(state, dtype=float)[2])
    return np.array([[np.cos(th) * dt, 0.0], [np.sin(th) * dt, 0.0],
                     [np.tan(steer) / wheelbase * dt, v * dt / (wheelbase * np.cos(steer) ** 2)]])


def control_noise_covariance(state, v, steer, wheelbase, dt, sigma_v, sigma_steer) -> np.ndarray:
    """V diag(sigma_v^2, sigma_steer^2) V^T with V the control Jacobian: the process noise of noisy controls."""
    V = bicycle_control_jacobian(state, v, steer, wheelbase, dt)
    return V @ np.diag([float(sigma_v) ** 2, float(sigma_steer) ** 2]) @ V.T
