"""Chapter 4: the chain rule in matrix form.

For a pipeline x -> u = f(x) -> g(u), the Jacobian of the whole is the product of the stages'
Jacobians, each evaluated at its own input: J(x) = Jg(f(x)) @ Jf(x). Order matters (Jg on the
left), and so does the evaluation point (Jg at u = f(x), not at x).

You may use your chapter 3 functions:
    from exercises.ch03_jacobian import polar_to_cartesian, polar_to_cartesian_jacobian
Run `grade ch04` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)


def g_stage(u):
    """The second stage of the pipeline.

    Formula: g(u) = (u1^2 + u2, u1 * u2).
    Arguments: u a 2-vector (list, tuple or array).
    Returns: a numpy array of shape (2,).
    Example: g_stage((2, 3)) -> array([7., 6.])
    """
    raise NotImplementedError


def g_jacobian(u):
    """The Jacobian of g_stage.

    Formula: Jg = [[2 u1, 1], [u2, u1]].
    Arguments: u a 2-vector.
    Returns: a numpy array of shape (2, 2).
    Example: g_jacobian((2, 3.4641)) -> [[4, 1], [3.4641, 2]]
    """
    raise NotImplementedError


def compose_jacobian(f, jac_f, jac_g, x):
    """The chain rule: the Jacobian of g(f(x)).

    Formula: Jg(f(x)) @ Jf(x).
    Arguments: f a function of one vector returning a vector; jac_f, jac_g functions of one
    vector returning matrices; x a vector.
    Returns: a numpy array of shape (m, n).
    Example: with f = polar_to_cartesian (as a function of v = (r, theta)), jac_f its Jacobian,
    jac_g = g_jacobian and x = (4, pi/3) -> [[2.866, -11.856], [3.464, -8.000]]
    """
    raise NotImplementedError


def pipeline_jacobian(r, theta):
    """The Jacobian of g_stage(polar_to_cartesian(r, theta)) with respect to (r, theta).

    Use compose_jacobian with your chapter 3 functions and g_jacobian.
    Arguments: r, theta real numbers.
    Returns: a numpy array of shape (2, 2).
    Example: pipeline_jacobian(4, pi/3) -> [[2.866, -11.856], [3.464, -8.000]]
    """
    raise NotImplementedError
