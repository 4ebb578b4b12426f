"""Chapter 5: numerical vs analytic Jacobians.

A finite difference estimates a derivative from function values. The forward difference has an
error of order h, the central difference of order h^2; but a too small h lets rounding error
(about eps |f| / h) take over, so the total error has a sweet spot. Comparing an analytic
Jacobian with a central-difference one ("the Jacobian check") catches hand-derivation mistakes.

Run `grade ch05` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)


def forward_difference(f, x, h):
    """Forward-difference estimate of f'(x).

    Formula: (f(x + h) - f(x)) / h.
    Arguments: f a scalar function of a scalar; x, h floats.
    Returns: a float.
    Example: forward_difference(np.sin, 1.0, 1e-3) -> 0.539881 (cos 1 = 0.540302)
    """
    raise NotImplementedError


def central_difference(f, x, h):
    """Central-difference estimate of f'(x).

    Formula: (f(x + h) - f(x - h)) / (2 h).
    Arguments: f a scalar function of a scalar; x, h floats.
    Returns: a float.
    Example: central_difference(np.sin, 1.0, 1e-5) -> cos(1) = 0.5403023 to about 1e-10
    """
    raise NotImplementedError


def jacobian_fd(f, x, h=1e-5):
    """The m x n central-difference Jacobian of a vector function f of one vector x.

    Column j is (f(x + h e_j) - f(x - h e_j)) / (2 h), e_j the j-th unit vector.
    Arguments: f a function of one vector returning a vector of length m; x a vector of length n
    (list, tuple or array; convert to float first); h the step.
    Returns: a numpy array of shape (m, n).
    Example: jacobian_fd(lambda v: polar_to_cartesian(*v), (4, pi/3))
             -> [[0.5, -3.4641], [0.8660, 2.0]] to about 1e-6
    """
    raise NotImplementedError


def max_jacobian_error(jac, f, x, h=1e-5):
    """The Jacobian check: the largest entry of |jac(x) - jacobian_fd(f, x, h)|.

    Arguments: jac and f functions of one vector (the analytic Jacobian and the function);
    x a vector; h the step.
    Returns: a float: about 0 (1e-9 or less) for a right Jacobian, large for a wrong one.
    Example: with the polar map and its Jacobian at (4, pi/3) -> about 1e-10
    """
    raise NotImplementedError


def best_step(f, fprime, x, hs):
    """The step h in hs whose central-difference error |central_difference(f, x, h) - f'(x)| is smallest.

    Arguments: f, fprime scalar functions; x a float; hs a sequence of steps.
    Returns: the best h (a float taken from hs).
    Example: best_step(np.sin, np.cos, 1.0, [1e-16, 1e-15, ..., 1e-1]) -> 1e-05 or 1e-06
    """
    raise NotImplementedError


if __name__ == "__main__":  # python exercises/ch05_finite_differences.py: the worked example with your functions
    for shown, call in [
        ('central_difference(np.sin, 1.0, 1e-5)', lambda: central_difference(np.sin, 1.0, 1e-5)),
        ('jacobian_fd(lambda v: np.array([v[0] * np.cos(v[1]), v[0] * np.sin(v[1])]), (4, np.pi / 3))',
         lambda: jacobian_fd(lambda v: np.array([v[0] * np.cos(v[1]), v[0] * np.sin(v[1])]), (4, np.pi / 3))),
    ]:
        try:
            print(shown, "=", call())
        except NotImplementedError:
            print(shown, "= not written yet (it raises NotImplementedError)")
    print("Then `grade ch05` grades the chapter.")
