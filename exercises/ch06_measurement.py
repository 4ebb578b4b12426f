"""Chapter 6: the range-bearing measurement Jacobian H.

A sensor at the origin measures z = (range, bearing) = (sqrt(x^2 + y^2), atan2(y, x)) of a drone at
(x, y). Its Jacobian H = dz/d(x, y) linearizes the sensor: a small position error dp becomes the
measurement error H dp, and a position covariance sigma^2 I becomes H (sigma^2 I) H^T. The bearing
row scales with 1/r: the closer the drone, the more sensitive the bearing.

Run `grade ch06` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)


def range_bearing(x, y):
    """The range-bearing measurement of the point (x, y).

    Formula: (r, bearing) = (sqrt(x^2 + y^2), atan2(y, x)); bearing in radians in [-pi, pi]
    (use atan2, not atan(y / x), so all four quadrants are right).
    Arguments: x, y real numbers.
    Returns: a numpy array of shape (2,).
    Example: range_bearing(3, 4) -> array([5., 0.9273])
    """
    raise NotImplementedError


def H_jacobian(x, y):
    """The Jacobian of range_bearing with respect to (x, y).

    Formula: H = [[dr/dx, dr/dy], [dbearing/dx, dbearing/dy]]
               = [[x/r, y/r], [-y/r^2, x/r^2]].
    Arguments: x, y real numbers.
    Returns: a numpy array of shape (2, 2).
    Raises: ValueError at r = 0, where the bearing is undefined.
    Example: H_jacobian(3, 4) -> [[0.6, 0.8], [-0.16, 0.12]]
    """
    raise NotImplementedError


def measurement_covariance(x, y, sigma):
    """The linearized measurement covariance of a position with covariance sigma^2 I.

    Formula: H (sigma^2 I) H^T = sigma^2 diag(1, 1/r^2).
    Arguments: x, y real numbers; sigma > 0 the position standard deviation.
    Returns: a numpy array of shape (2, 2).
    Raises: ValueError at r = 0.
    Example: measurement_covariance(3, 4, 1.0) -> diag(1, 0.04)
    """
    raise NotImplementedError
