"""Chapter 5's expected values: exact derivatives of the catalogue's scalar functions, the intervals a
right forward or central difference's error lies in, exact Jacobians of the catalogue's maps, and
the central-difference errors best_step chooses from.

Error bounds (grader/checks/ch05.py says why they separate right from wrong):
- central: (f(x+h) - f(x-h)) / 2h - f'(x) = h^2/12 (f3(a) + f3(b)) for some a, b in [x-h, x+h]
  (f3 the third derivative), so |error| <= h^2/6 M3 (M3 = max |f3| on [x-h, x+h], on a fine grid, +5%);
- forward: (f(x+h) - f(x)) / h - f'(x) = h/2 f''(c) for some c in [x, x+h], so the error lies in
  h/2 [min f'', max f''] on [x, x+h] (+-2% of its width and size);
- rounding, for both: each f value within eps |f|, each argument x +- h within eps/2 (|x| + h):
  at most 2 eps (M0 + (|x| + h) M1) / h.
"""

from __future__ import annotations

import numpy as np

from grader.catalogue import CALLABLES
from solutions.ch05_finite_differences import central_difference, forward_difference

EPS = float(np.finfo(float).eps)
GRID = 201


def _c(value):
    return lambda x: np.full_like(np.asarray(x, dtype=float), value)


# catalogue name -> ([f, f', f'', f3] as numpy functions, size of f's terms)
SCALAR = {
    "sin": ([np.sin, np.cos, lambda x: -np.sin(x), lambda x: -np.cos(x)], lambda x: 1.0 + 0 * x),
    "exp": ([np.exp] * 4, np.exp),
    "cubic": ([lambda x: x**3 - 2 * x, lambda x: 3 * x**2 - 2, lambda x: 6 * x, _c(6.0)],
              lambda x: np.abs(x) ** 3 + 2 * np.abs(x)),
    "sqrt": ([np.sqrt, lambda x: 0.5 * x**-0.5, lambda x: -0.25 * x**-1.5, lambda x: 0.375 * x**-2.5], np.sqrt),
    "log": ([np.log, lambda x: 1 / x, lambda x: -1 / x**2, lambda x: 2 / x**3], lambda x: np.abs(np.log(x)) + 1.0),
}


def _derivative(name: str, order: int, x):
    return SCALAR[name][0][order](np.asarray(x, dtype=float))


def _grid(a: float, b: float) -> np.ndarray:
    return np.linspace(a, b, GRID)


def _rounding(name: str, x: float, h: float, a: float, b: float) -> float:
    xs = _grid(a, b)
    m0 = float(np.max(SCALAR[name][1](xs)))
    m1 = float(np.max(np.abs(_derivative(name, 1, xs))))
    return 2 * EPS * (m0 + (abs(x) + h) * m1) / h + 4 * EPS * abs(float(_derivative(name, 1, x)))


def exact_derivative(name: str, x: float) -> float:
    return float(_derivative(name, 1, float(x)))


def difference_law(name: str, x: float, h: float) -> dict:
    """For catalogue function `name` at x with step h: the exact f'(x), the intervals the errors
    (result - f'(x)) of a right central and forward difference lie in, and both differences' values."""
    x = float(x)
    m3 = float(np.max(np.abs(_derivative(name, 3, _grid(x - h, x + h)))))
    half = 1.05 * h * h / 6 * m3 + _rounding(name, x, h, x - h, x + h)
    second = _derivative(name, 2, _grid(x, x + h))
    low, high = h / 2 * float(second.min()), h / 2 * float(second.max())
    slack = 0.02 * (high - low) + 0.02 * h / 2 * float(np.abs(second).max()) + _rounding(name, x, h, x, x + h)
    f = CALLABLES[name]
    return {"exact": exact_derivative(name, x), "central": (-half, half), "forward": (low - slack, high + slack),
            "central_value": central_difference(f, x, h), "forward_value": forward_difference(f, x, h)}


def best_step_errors(f: str, fprime: str, x: float, hs) -> tuple[list, float]:
    """|central difference - f'(x)| at every h, computed as a learner's function would, and the floor
    eps max(1, |f'(x)|) under the smallest (one step may hit the exact value)."""
    function, derivative = CALLABLES[f], CALLABLES[fprime]
    slope = float(derivative(x))
    return [abs(central_difference(function, x, h) - slope) for h in hs], EPS * max(1.0, abs(slope))


_JACOBIANS = {"mix_vec": "mix_jac", "shear_vec": "shear_jac", "twist_vec": "twist_jac",
              "two_of_three_vec": "two_of_three_jac"}


def jacobian_of(name: str, point) -> np.ndarray:
    """The exact Jacobian of catalogue map `name` at `point`."""
    point = np.asarray(point, dtype=float)
    if name == "polar_twin_vec":
        d = point - np.array([4.0, np.pi / 3])
        base = np.array([[0.5, -2 * np.sqrt(3.0)], [np.sqrt(3.0) / 2, 2.0]])
        return base + np.array([[d[1], d[0]], [d[0], -2 * d[1]]])
    return np.asarray(CALLABLES[_JACOBIANS[name]](point), dtype=float)


def jacobian_gap(jac: str, f: str, point) -> float:
    """max |jac(x) - J(x)| for catalogue Jacobian `jac` of map `f`: what the Jacobian check must say."""
    point = np.asarray(point, dtype=float)
    return float(np.max(np.abs(np.asarray(CALLABLES[jac](point), dtype=float) - jacobian_of(f, point))))


def jacobian_fd_of(name: str, point, h: float, form: str = "central") -> np.ndarray:
    """The difference-quotient Jacobian of catalogue map `name` at `point` with step h, exactly as the
    contract's formula gives it ("central"), or as a slip gives it ("forward", "half step")."""
    f = CALLABLES[name]
    point = np.asarray(point, dtype=float)
    columns = []
    for j in range(point.size):
        e = np.zeros_like(point)
        e[j] = h
        plus = np.atleast_1d(np.asarray(f(point + e), dtype=float))
        if form == "forward":
            columns.append((plus - np.atleast_1d(np.asarray(f(point), dtype=float))) / h)
        elif form == "half step":  # a central difference with step h/2: x moved by h/2, divided by h
            columns.append((np.atleast_1d(np.asarray(f(point + e / 2), dtype=float))
                            - np.atleast_1d(np.asarray(f(point - e / 2), dtype=float))) / h)
        else:
            columns.append((plus - np.atleast_1d(np.asarray(f(point - e), dtype=float))) / (2 * h))
    return np.stack(columns, axis=1)


def signed_jacobian_gap(jac: str, f: str, point) -> float:
    """max(jac(x) - J(x)) without the absolute value."""
    point = np.asarray(point, dtype=float)
    return float(np.max(np.asarray(CALLABLES[jac](point), dtype=float) - jacobian_of(f, point)))
