"""Chapter 4: the chain rule in matrix form, J_{g o f}(x) = Jg(f(x)) Jf(x)."""

from __future__ import annotations

import numpy as np

from .ch03_jacobian import polar_to_cartesian, polar_to_cartesian_jacobian


def g_stage(u) -> np.ndarray:
    """(u1^2 + u2, u1 u2)."""
    u1, u2 = np.asarray(u, dtype=float)
    return np.array([u1**2 + u2, u1 * u2])


def g_jacobian(u) -> np.ndarray:
    """[[2 u1, 1], [u2, u1]]."""
    u1, u2 = np.asarray(u, dtype=float)
    return np.array([[2 * u1, 1.0], [u2, u1]])


def compose_jacobian(f, jac_f, jac_g, x) -> np.ndarray:
    """Jg(f(x)) @ Jf(x)."""
    x = np.asarray(x, dtype=float)
    return np.asarray(jac_g(f(x)), dtype=float) @ np.asarray(jac_f(x), dtype=float)


def pipeline_jacobian(r, theta) -> np.ndarray:
    """Jacobian of g_stage(polar_to_cartesian(r, theta)) with respect to (r, theta)."""
    return compose_jacobian(lambda v: polar_to_cartesian(*v),
                            lambda v: polar_to_cartesian_jacobian(*v), g_jacobian, [r, theta])


def _rotation(phi: float) -> np.ndarray:
    """The 2-D rotation by phi."""
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


def lidar_to_world(r, theta, pose) -> np.ndarray:
    """A lidar return (r, theta) in the world frame: R(phi) polar_to_cartesian(r, theta) + (px, py)."""
    px, py, phi = np.asarray(pose, dtype=float)
    return _rotation(phi) @ polar_to_cartesian(r, theta) + np.array([px, py])


def lidar_to_world_jacobian(r, theta, pose) -> np.ndarray:
    """d lidar_to_world / d(r, theta): the rotation (a constant linear stage) after the polar Jacobian."""
    phi = float(np.asarray(pose, dtype=float)[2])
    return compose_jacobian(lambda v: polar_to_cartesian(*v), lambda v: polar_to_cartesian_jacobian(*v),
                            lambda u: _rotation(phi), [r, theta])


def lidar_pose_jacobian(r, theta, pose) -> np.ndarray:
    """d lidar_to_world / d(px, py, phi): identity in the translation, dR/dphi times the local point."""
    phi = float(np.asarray(pose, dtype=float)[2])
    local = polar_to_cartesian(r, theta)
    turned = _rotation(phi + np.pi / 2) @ local  # dR/dphi = R(phi + pi/2)
    return np.column_stack([np.eye(2), turned])
