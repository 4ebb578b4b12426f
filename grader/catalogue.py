"""The fixed catalogue of callables the grader may hand to learner functions, by name.

A check passes `Fn("sqrt")`; the child looks the name up here. Every entry follows the contract's
convention: scalar callables work elementwise on arrays, "vector" callables take one vector.

Learner code can read this module (it runs in the child, beside learner code), so nothing here
computes an exercise's function or derivative: the maps are others than the lesson's. Where the
lesson's worked example hands a lesson map to the learner's function (jacobian_fd of the polar map,
tangent_plane and hessian_fd of x^2 + x y), a "twin" stands in: a map that agrees with the lesson's
in value, first and second derivatives at that one point, and in nothing else. Only numpy here.
"""

from __future__ import annotations

import numpy as np


def _vec(v) -> np.ndarray:
    return np.asarray(v, dtype=float)


# ------------------------------------------------------------------------------ scalar functions

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


# ------------------------------------------------------------------------------ maps R^2 -> R^2 (and their Jacobians)

def mix_vec(v):
    """(x, y) -> (x y, x^2 - y)."""
    x, y = _vec(v)
    return np.array([x * y, x * x - y])


def mix_jac(v):
    x, y = _vec(v)
    return np.array([[y, x], [2 * x, -1.0]])


def shear_vec(v):
    """(x, y) -> (x + y^2, sin x)."""
    x, y = _vec(v)
    return np.array([x + y * y, np.sin(x)])


def shear_jac(v):
    x, y = _vec(v)
    return np.array([[1.0, 2 * y], [np.cos(x), 0.0]])


def twist_vec(v):
    """(x, y) -> (e^(x/3) cos y, x - y^3 / 3)."""
    x, y = _vec(v)
    return np.array([np.exp(x / 3) * np.cos(y), x - y**3 / 3])


def twist_jac(v):
    x, y = _vec(v)
    return np.array([[np.exp(x / 3) * np.cos(y) / 3, -np.exp(x / 3) * np.sin(y)], [1.0, -y * y]])


def twist_jac_transposed(v):
    """A deliberately wrong Jacobian (transposed), for 'the Jacobian check' to catch."""
    return twist_jac(v).T


def mix_jac_sign_slip(v):
    """A deliberately wrong Jacobian of mix_vec: d(x^2 - y)/dx = -2x (sign slip)."""
    x, y = _vec(v)
    return np.array([[y, x], [-2 * x, -1.0]])


# ------------------------------------------------------------------------------ R^3 -> R^2

def two_of_three_vec(p):
    """(x, y, z) -> (x y + sin z, x^2 z - y): R^3 -> R^2, a non-square Jacobian."""
    x, y, z = _vec(p)
    return np.array([x * y + np.sin(z), x * x * z - y])


def two_of_three_jac(p):
    x, y, z = _vec(p)
    return np.array([[y, x, np.cos(z)], [2 * x * z, -1.0, x * x]])


# ------------------------------------------------------------------------------ scalar functions of a vector

def bowl_vec(p):
    """g(x, y) = x^2 + 0.5 x y + y^2 (the lesson's bowl; its gradient is the learner's to write)."""
    x, y = _vec(p)
    return x * x + 0.5 * x * y + y * y


def wave_vec(p):
    """f(x, y) = y sin x + x^2 / 2."""
    x, y = _vec(p)
    return y * np.sin(x) + 0.5 * x * x


def wave_grad_vec(p):
    x, y = _vec(p)
    return np.array([y * np.cos(x) + x, np.sin(x)])


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


def rosenbrock_grad_vec(p):
    x, y = _vec(p)
    return np.array([-2 * (1 - x) - 400 * x * (y - x * x), 200 * (y - x * x)])


# ------------------------------------------------------------------------------ twins of the lesson's maps

_TWIN_POINT = np.array([4.0, np.pi / 3])
_TWIN_VALUE = np.array([2.0, 2 * np.sqrt(3.0)])
_TWIN_JACOBIAN = np.array([[0.5, -2 * np.sqrt(3.0)], [np.sqrt(3.0) / 2, 2.0]])


def polar_twin_vec(v):
    """A quadratic map with the polar map's value and Jacobian at (4, pi/3) and no more in common
    (a central difference of a quadratic is exact, so jacobian_fd there gives that Jacobian)."""
    d = _vec(v) - _TWIN_POINT
    return _TWIN_VALUE + _TWIN_JACOBIAN @ d + np.array([d[0] * d[1], 0.5 * d[0] * d[0] - d[1] * d[1]])


def plane_twin_vec(p):
    """3 + 4 dx + dy + 2 dx^2 - dy^2 around (1, 2): the value 3 and gradient (4, 1) of x^2 + x y there."""
    dx, dy = _vec(p) - np.array([1.0, 2.0])
    return 3 + 4 * dx + dy + 2 * dx * dx - dy * dy


def plane_twin_grad_vec(p):
    dx, dy = _vec(p) - np.array([1.0, 2.0])
    return np.array([4 + 4 * dx, 1 - 2 * dy])


def hessian_twin_vec(p):
    """2 e^dx + dx dy + dy^3 around (1, 2): the Hessian [[2, 1], [1, 0]] of x^2 + x y there."""
    dx, dy = _vec(p) - np.array([1.0, 2.0])
    return 2 * np.exp(dx) + dx * dy + dy**3


def hessian_twin_grad_vec(p):
    dx, dy = _vec(p) - np.array([1.0, 2.0])
    return np.array([2 * np.exp(dx) + dy, dx + 3 * dy * dy])


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
    "mix_vec": mix_vec,
    "mix_jac": mix_jac,
    "mix_jac_sign_slip": mix_jac_sign_slip,
    "shear_vec": shear_vec,
    "shear_jac": shear_jac,
    "twist_vec": twist_vec,
    "twist_jac": twist_jac,
    "twist_jac_transposed": twist_jac_transposed,
    "two_of_three_vec": two_of_three_vec,
    "two_of_three_jac": two_of_three_jac,
    "bowl_vec": bowl_vec,
    "wave_vec": wave_vec,
    "wave_grad_vec": wave_grad_vec,
    "saddle3_vec": saddle3_vec,
    "saddle3_grad_vec": saddle3_grad_vec,
    "rosenbrock_vec": rosenbrock_vec,
    "rosenbrock_grad_vec": rosenbrock_grad_vec,
    "polar_twin_vec": polar_twin_vec,
    "plane_twin_vec": plane_twin_vec,
    "plane_twin_grad_vec": plane_twin_grad_vec,
    "hessian_twin_vec": hessian_twin_vec,
    "hessian_twin_grad_vec": hessian_twin_grad_vec,
}
