"""Chapter 4's expected values: the two-stage pipeline, and the chain rule on catalogue maps with
its usual slips (the check names the slip a wrong answer matches)."""

from __future__ import annotations

import numpy as np

from grader.catalogue import CALLABLES
from solutions.ch03_jacobian import polar_to_cartesian
from solutions.ch04_chain_rule import compose_jacobian, g_stage


def pipeline_forward(r, theta) -> np.ndarray:
    """g_stage(polar_to_cartesian(r, theta))."""
    return g_stage(polar_to_cartesian(r, theta))


def compose_candidates(f: str, jac_f: str, jac_g: str, x) -> dict:
    """The right composed Jacobian of catalogue maps at x, and what the usual slips give instead."""
    f, jac_f, jac_g = CALLABLES[f], CALLABLES[jac_f], CALLABLES[jac_g]
    x = np.asarray(x, dtype=float)
    jf, jg_at_fx, jg_at_x = jac_f(x), jac_g(f(x)), jac_g(x)
    return {"right": compose_jacobian(f, jac_f, jac_g, x), "order": jf @ jg_at_fx, "at_x": jg_at_x @ jf,
            "at_x_and_order": jf @ jg_at_x, "elementwise": jg_at_fx * jf}





def pipeline_mistakes(r, theta) -> dict:
    """What the usual chain-rule slips give for the two-stage pipeline."""
    from solutions.ch03_jacobian import polar_to_cartesian_jacobian
    from solutions.ch04_chain_rule import g_jacobian

    inner, outer = polar_to_cartesian_jacobian(r, theta), g_jacobian(polar_to_cartesian(r, theta))
    return {"order": inner @ outer, "at_x": g_jacobian([r, theta]) @ inner}


__all__ = ["compose_candidates", "lidar_jacobian_mistakes", "lidar_mistakes", "lidar_pose_mistakes", "pipeline_forward",
           "pipeline_mistakes", "polar_to_cartesian"]


def lidar_mistakes(r, theta, pose) -> dict:
    """lidar_to_world without the rotation, rotated by -phi, or without the translation."""
    from solutions.ch04_chain_rule import _rotation

    px, py, phi = np.asarray(pose, dtype=float)
    local = polar_to_cartesian(r, theta)
    return {"missing rotation": local + np.array([px, py]),
            "rotation transposed": _rotation(-phi) @ local + np.array([px, py]),
            "missing translation": _rotation(phi) @ local}


def lidar_jacobian_mistakes(r, theta, pose) -> dict:
    """What the usual slips give for the Jacobian of lidar_to_world with respect to (r, theta)."""
    from solutions.ch03_jacobian import polar_to_cartesian_jacobian
    from solutions.ch04_chain_rule import _rotation

    phi = float(np.asarray(pose, dtype=float)[2])
    inner = polar_to_cartesian_jacobian(r, theta)
    return {"order": inner @ _rotation(phi), "missing rotation": inner, "rotation transposed": _rotation(-phi) @ inner}


def lidar_pose_mistakes(r, theta, pose) -> dict:
    """What the usual slips give for the Jacobian of lidar_to_world with respect to the pose (px, py, phi)."""
    from solutions.ch04_chain_rule import lidar_pose_jacobian, lidar_to_world

    right = lidar_pose_jacobian(r, theta, pose)
    world = lidar_to_world(r, theta, pose)
    missing_derivative, world_point, missing_identity = right.copy(), right.copy(), right.copy()
    missing_derivative[:, 2] = 0.0
    world_point[:, 2] = [-world[1], world[0]]
    missing_identity[:, :2] = 0.0
    return {"missing rotation derivative": missing_derivative, "world point": world_point,
            "missing identity": missing_identity}
