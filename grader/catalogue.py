"""The fixed catalogue of callables the grader may hand to learner functions, by name.

A check passes `{"$fn": "sqrt"}`; the child looks the name up here. Every entry follows the
contract's convention: scalar callables work elementwise on arrays, "vector" callables take one
vector argument. Only numpy: this module is imported inside the child process.
"""

from __future__ import annotations

import numpy as np


def _vec(v) -> np.ndarray:
    return np.asarray(v, dtype=float)


def polar_vec(v):
    """(r, theta) -> (r cos theta, r sin theta)."""
    r, theta = _vec(v)
    return np.array([r * np.cos(theta), r * np.sin(theta)])


def polar_jac(v):
    r, theta = _vec(v)
    return np.array([[np.cos(theta), -r * np.sin(theta)], [np.sin(theta), r * np.cos(theta)]])


def g_stage_vec(u):
    """(u1, u2) -> (u1^2 + u2, u1 u2)."""
    u1, u2 = _vec(u)
    return np.array([u1**2 + u2, u1 * u2])


def g_jac(u):
    u1, u2 = _vec(u)
    return np.array([[2 * u1, 1.0], [u2, u1]])


def range_bearing_vec(p):
    x, y = _vec(p)
    return np.array([np.hypot(x, y), np.arctan2(y, x)])


def range_bearing_jac(p):
    x, y = _vec(p)
    r2 = x * x + y * y
    r = np.sqrt(r2)
    return np.array([[x / r, y / r], [-y / r2, x / r2]])


def range_bearing_jac_transposed(p):
    """A deliberately wrong Jacobian (transposed), for 'the Jacobian check' to catch."""
    return range_bearing_jac(p).T


def example_f_vec(p):
    """f(x, y) = x^2 + x y as a function of one vector."""
    x, y = _vec(p)
    return x * x + x * y


def example_grad_vec(p):
    x, y = _vec(p)
    return np.array([2 * x + y, x])


def bowl_vec(p):
    """g(x, y) = x^2 + 0.5 x y + y^2."""
    x, y = _vec(p)
    return x * x + 0.5 * x * y + y * y


def bowl_grad_vec(p):
    x, y = _vec(p)
    return np.array([2 * x + 0.5 * y, 0.5 * x + 2 * y])


def saddle3_vec(p):
    """x^2 - y^2 + 3 x z + z^3 - y z: a cubic with a non-constant, non-diagonal Hessian."""
    x, y, z = _vec(p)
    return x * x - y * y + 3 * x * z + z**3 - y * z


def saddle3_grad_vec(p):
    x, y, z = _vec(p)
    return np.array([2 * x + 3 * z, -2 * y - z, 3 * x + 3 * z * z - y])


def rosenbrock_vec(p):
    x, y = _vec(p)
    return (1 - x) ** 2 + 100 * (y - x * x) ** 2


def two_of_three_vec(p):
    """(x, y, z) -> (x y + sin z, x^2 z - y): R^3 -> R^2, a non-square Jacobian."""
    x, y, z = _vec(p)
    return np.array([x * y + np.sin(z), x * x * z - y])


def two_of_three_jac(p):
    x, y, z = _vec(p)
    return np.array([[y, x, np.cos(z)], [2 * x * z, -1.0, x * x]])


def polar_jac_sign_slip(p):
    """A deliberately wrong polar Jacobian: d x/d theta = +r sin theta (sign slip)."""
    r, theta = _vec(p)
    return np.array([[np.cos(theta), r * np.sin(theta)], [np.sin(theta), r * np.cos(theta)]])


def cubic(x):
    return x**3 - 2 * x


def cubic_prime(x):
    return 3 * x**2 - 2


def cubic_second(x):
    return 6 * x


def sqrt_prime(x):
    return 0.5 / np.sqrt(x)


def sqrt_second(x):
    return -0.25 * np.asarray(x, dtype=float) ** -1.5


def neg_sin(x):
    return -np.sin(x)


CALLABLES = {
    "sqrt": np.sqrt,
    "sqrt_prime": sqrt_prime,
    "sqrt_second": sqrt_second,
    "sin": np.sin,
    "cos": np.cos,
    "neg_sin": neg_sin,
    "exp": np.exp,
    "log": np.log,
    "reciprocal": np.reciprocal,
    "cubic": cubic,
    "cubic_prime": cubic_prime,
    "cubic_second": cubic_second,
    "polar_vec": polar_vec,
    "polar_jac": polar_jac,
    "g_stage_vec": g_stage_vec,
    "g_jac": g_jac,
    "range_bearing_vec": range_bearing_vec,
    "range_bearing_jac": range_bearing_jac,
    "range_bearing_jac_transposed": range_bearing_jac_transposed,
    "example_f_vec": example_f_vec,
    "example_grad_vec": example_grad_vec,
    "bowl_vec": bowl_vec,
    "bowl_grad_vec": bowl_grad_vec,
    "saddle3_vec": saddle3_vec,
    "saddle3_grad_vec": saddle3_grad_vec,
    "rosenbrock_vec": rosenbrock_vec,
    "two_of_three_vec": two_of_three_vec,
    "two_of_three_jac": two_of_three_jac,
    "polar_jac_sign_slip": polar_jac_sign_slip,
}
