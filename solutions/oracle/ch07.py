"""Chapter 7's expected values beyond the reference solution: the arc motion model (the usual slip for
the lesson's Euler step)."""

from __future__ import annotations

import numpy as np


def arc_motion(state, v, omega, dt) -> np.ndarray:
    """The exact constant-turn-rate motion instead of the lesson's Euler step."""
    x, y, th = np.asarray(state, dtype=float)
    return np.array([x + v / omega * (np.sin(th + omega * dt) - np.sin(th)),
                     y - v / omega * (np.cos(th + omega * dt) - np.cos(th)), th + omega * dt])


def bicycle_mistakes(state, v, steer, wheelbase, dt) -> dict:
    """bicycle_model without dt, with the steering angle taken as a turn rate, without the wheelbase or times it,
    or with steer for tan(steer)."""
    from solutions.ch07_dynamics import bicycle_model

    x, y, th = np.asarray(state, dtype=float)
    right = bicycle_model(state, v, steer, wheelbase, dt)
    turned = {"steer as turn rate": th + steer * dt, "missing wheelbase": th + v * np.tan(steer) * dt,
              "steer for tan(steer)": th + v * steer / wheelbase * dt,
              "times the wheelbase": th + v * np.tan(steer) * wheelbase * dt}
    slips = {name: np.array([right[0], right[1], heading]) for name, heading in turned.items()}
    slips["missing dt"] = bicycle_model(state, v, steer, wheelbase, 1.0)
    return slips


def bicycle_jacobian_mistakes(state, v, steer, wheelbase, dt) -> dict:
    """What the usual slips in differentiating bicycle_model with respect to (v, steer) give."""
    from solutions.ch07_dynamics import bicycle_control_jacobian

    right = bicycle_control_jacobian(state, v, steer, wheelbase, dt)
    slips = {"missing 1/cos^2": v * dt / wheelbase, "1/cos for 1/cos^2": v * dt / (wheelbase * np.cos(steer)),
             "tan for 1/cos^2": v * dt * np.tan(steer) / wheelbase}
    out = {}
    for name, entry in slips.items():
        out[name] = right.copy()
        out[name][2, 1] = entry
    out["missing dt"] = bicycle_control_jacobian(state, v, steer, wheelbase, 1.0)
    return out


def control_noise_mistakes(state, v, steer, wheelbase, dt, sigma_v, sigma_steer) -> dict:
    """V diag(sigma_v, sigma_steer) V^T (sigmas not squared) and the sigmas swapped."""
    from solutions.ch07_dynamics import control_noise_covariance

    return {"sigma not squared": control_noise_covariance(state, v, steer, wheelbase, dt, np.sqrt(sigma_v),
                                                          np.sqrt(sigma_steer)),
            "sigmas swapped": control_noise_covariance(state, v, steer, wheelbase, dt, sigma_steer, sigma_v)}
