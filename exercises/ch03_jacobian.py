"""Chapter 3: the Jacobian.

For a map from n inputs to m outputs, the Jacobian is the m x n matrix of partial derivatives,
J[i, j] = d f_i / d x_j (a row per output, a column per input). For polar -> Cartesian,
(r, theta) -> (r cos theta, r sin theta), the theta column is scaled by r, and det J = r: a small
patch of area dr dtheta becomes area r dr dtheta.

Run `grade ch03` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)


def polar_to_cartesian(r, theta):
    """Polar coordinates to Cartesian.

    Formula: (x, y) = (r cos theta, r sin theta); theta in radians.
    Arguments: r, theta real numbers.
    Returns: a numpy array of shape (2,).
    Example: polar_to_cartesian(4, pi/3) -> array([2., 3.4641])
    """
    raise NotImplementedError


def polar_to_cartesian_jacobian(r, theta):
    """The Jacobian of polar_to_cartesian with respect to (r, theta).

    Formula: J = [[dx/dr, dx/dtheta], [dy/dr, dy/dtheta]]
               = [[cos theta, -r sin theta], [sin theta, r cos theta]].
    Arguments: r, theta real numbers.
    Returns: a numpy array of shape (2, 2).
    Example: polar_to_cartesian_jacobian(4, pi/3) -> [[0.5, -3.4641], [0.8660, 2.0]]
    """
    raise NotImplementedError


def area_scale(r, theta):
    """The signed determinant of the polar Jacobian: how much the map scales small areas.

    Formula: det J = cos theta * r cos theta - (-r sin theta) * sin theta = r.
    Arguments: r, theta real numbers.
    Returns: a float.
    Example: area_scale(4, pi/3) -> 4.0
    """
    raise NotImplementedError
