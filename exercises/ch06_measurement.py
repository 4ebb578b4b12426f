"""Chapter 6: the range-bearing measurement Jacobian H.

A sensor at the origin measures z = (range, bearing) = (sqrt(x^2 + y^2), atan2(y, x)) of a drone at
(x, y). Its Jacobian H = dz/d(x, y) linearizes the sensor: a small position error dp becomes the
measurement error H dp, and a position covariance sigma^2 I becomes H (sigma^2 I) H^T.

The 3-D functions come from the lesson's range-bearing-elevation sensor (chapter 6, "when to reach
for it"): the same idea one dimension up, which the lesson does not work out for you.

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

    Rows are the outputs (range, bearing), columns the inputs (x, y). Differentiate by hand (or by
    autograd in float64); the grader checks the result exactly, close to the dish too.
    Arguments: x, y real numbers.
    Returns: a numpy array of shape (2, 2).
    Raises: ValueError at r = 0, where the bearing is undefined.
    Example: H_jacobian(3, 4) -> [[0.6, 0.8], [-0.16, 0.12]]
    """
    raise NotImplementedError


def measurement_covariance(x, y, sigma):
    """The linearized measurement covariance of a position with covariance sigma^2 I.

    Formula: H (sigma^2 I) H^T, with H = H_jacobian(x, y).
    Arguments: x, y real numbers; sigma > 0 the position standard deviation.
    Returns: a numpy array of shape (2, 2).
    Raises: ValueError at r = 0.
    Example: measurement_covariance(3, 4, 1.0) -> diag(1, 0.04)
    """
    raise NotImplementedError


def range_bearing_elevation(x, y, z):
    """The range, bearing and elevation of the point (x, y, z), seen from a 3-D sensor at the origin.

    Formula: (sqrt(x^2 + y^2 + z^2), atan2(y, x), atan2(z, sqrt(x^2 + y^2))); the elevation is the
    angle above the x-y plane; radians.
    Arguments: x, y, z real numbers.
    Returns: a numpy array of shape (3,).
    Example: range_bearing_elevation(3, 4, 0) -> array([5., 0.9273, 0.])
    """
    raise NotImplementedError


def H3_jacobian(x, y, z):
    """The Jacobian of range_bearing_elevation with respect to (x, y, z).

    Rows are the outputs (range, bearing, elevation), columns the inputs (x, y, z). Derive every
    entry by hand; the grader compares it with finite differences of your range_bearing_elevation
    and checks that it is exact. Graded where x^2 + y^2 >= 0.1.
    Arguments: x, y, z real numbers.
    Returns: a numpy array of shape (3, 3).
    Raises: ValueError where x = y = 0 (on the z-axis the bearing is undefined), and nowhere else.
    Example: H3_jacobian(1, 0, 1) -> [[0.7071, 0, 0.7071], [0, 1, 0], [-0.5, 0, 0.5]]
    """
    raise NotImplementedError


if __name__ == "__main__":  # python exercises/ch06_measurement.py: the worked example with your functions
    for shown, call in [
        ('range_bearing(3, 4)', lambda: range_bearing(3, 4)),
        ('H_jacobian(3, 4)', lambda: H_jacobian(3, 4)),
        ('measurement_covariance(3, 4, 1.0)', lambda: measurement_covariance(3, 4, 1.0)),
    ]:
        try:
            print(shown, "=", call())
        except NotImplementedError:
            print(shown, "= not written yet (it raises NotImplementedError)")
    print("Then `grade ch06` grades the chapter.")
