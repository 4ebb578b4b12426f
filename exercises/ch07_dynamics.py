"""Chapter 7: the motion-model Jacobian F and covariance propagation.

A robot at state (x, y, theta) driving at speed v and turning at rate omega for dt moves to
(x + v cos(theta) dt, y + v sin(theta) dt, theta + omega dt). Its Jacobian F = d(new state)/d(state)
carries the uncertainty forward: P_new = F P F^T (+ Q). Heading uncertainty turns into position
uncertainty across the direction of travel, which is why F P F^T gets nonzero off-diagonals.

Run `grade ch07` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)


def motion_model(state, v, omega, dt):
    """One step of the unicycle motion model.

    Formula: (x + v cos(theta) dt, y + v sin(theta) dt, theta + omega dt).
    Arguments: state a 3-vector (x, y, theta); v, omega, dt floats.
    Returns: a numpy array of shape (3,).
    Example: motion_model((0, 0, pi/6), 2.0, 0.5, 0.1) -> array([0.1732, 0.1, 0.5736])
    """
    raise NotImplementedError


def F_jacobian(state, v, omega, dt):
    """The Jacobian of motion_model with respect to the state (x, y, theta).

    Formula: F = [[1, 0, -v sin(theta) dt], [0, 1, v cos(theta) dt], [0, 0, 1]].
    Arguments: as motion_model.
    Returns: a numpy array of shape (3, 3).
    Example: state (0, 0, pi/6), v = 2, dt = 0.1 -> F[0, 2] = -0.1, F[1, 2] = 0.1732
    """
    raise NotImplementedError


def propagate_covariance(P, F, Q=None):
    """Carry a covariance through a linearized step.

    Formula: F P F^T, plus Q when Q is given.
    Arguments: P an n x n covariance; F an n x n Jacobian; Q None or an n x n process noise.
    Returns: a numpy array of shape (n, n), symmetric positive semi-definite.
    Example: P = diag(0.04, 0.04, 0.01) with the F above ->
             [[0.0401, -0.000173, -0.001], [-0.000173, 0.0403, 0.001732], [-0.001, 0.001732, 0.01]]
    """
    raise NotImplementedError
