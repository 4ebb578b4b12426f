"""Chapter 3: the Jacobian.

For a map from n inputs to m outputs, the Jacobian is the m x n matrix of partial derivatives,
J[i, j] = d f_i / d x_j (a row per output, a column per input). Its determinant, for a square J,
says how the map scales small areas (or volumes) near the point.

The spherical functions come from the lesson's 3-D dish story (chapter 3, "when to reach for it"):
a map the lesson does not work out. Derive its Jacobian by hand.

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

    Rows are the outputs (x, y), columns the inputs (r, theta): J[i, j] = d output_i / d input_j.
    Differentiate by hand; the grader checks the result exactly.
    Arguments: r, theta real numbers.
    Returns: a numpy array of shape (2, 2).
    Example: polar_to_cartesian_jacobian(4, pi/3) -> [[0.5, -3.4641], [0.8660, 2.0]]
    """
    raise NotImplementedError


def area_scale(r, theta):
    """How much the polar map scales small areas at (r, theta): the signed determinant of its Jacobian.

    Arguments: r, theta real numbers.
    Returns: a float (signed: no absolute value).
    Example: area_scale(4, pi/3) -> 4.0
    """
    raise NotImplementedError


def spherical_to_cartesian(r, azimuth, elevation):
    """Spherical coordinates (a 3-D dish's range, azimuth and elevation) to Cartesian.

    Formula: (x, y, z) = (r cos(elevation) cos(azimuth), r cos(elevation) sin(azimuth), r sin(elevation));
    the elevation is the angle above the x-y plane, the azimuth is measured in that plane from the
    x-axis; both in radians.
    Arguments: r, azimuth, elevation real numbers.
    Returns: a numpy array of shape (3,).
    Example: spherical_to_cartesian(2, 0, 0) -> array([2., 0., 0.])
    """
    raise NotImplementedError


def spherical_to_cartesian_jacobian(r, azimuth, elevation):
    """The Jacobian of spherical_to_cartesian with respect to (r, azimuth, elevation).

    Rows are the outputs (x, y, z), columns the inputs (r, azimuth, elevation). Derive every entry
    by hand; the grader compares it with finite differences of your spherical_to_cartesian and
    checks that it is exact, close to the poles too. Graded at r >= 0.3 and |elevation| <= 1.4.
    Arguments: r, azimuth, elevation real numbers.
    Returns: a numpy array of shape (3, 3).
    Example: spherical_to_cartesian_jacobian(2, 0, 0) -> diag(1, 2, 2)
    """
    raise NotImplementedError


def volume_scale(r, azimuth, elevation):
    """How much the spherical map scales small volumes: the signed determinant of its Jacobian.

    Arguments: r, azimuth, elevation real numbers.
    Returns: a float (signed: no absolute value).
    Example: volume_scale(2, 0, 0) -> 4.0
    """
    raise NotImplementedError


if __name__ == "__main__":  # python exercises/ch03_jacobian.py: the worked example with your functions
    for shown, call in [
        ('polar_to_cartesian(4, np.pi / 3)', lambda: polar_to_cartesian(4, np.pi / 3)),
        ('polar_to_cartesian_jacobian(4, np.pi / 3)', lambda: polar_to_cartesian_jacobian(4, np.pi / 3)),
        ('area_scale(4, np.pi / 3)', lambda: area_scale(4, np.pi / 3)),
        ('spherical_to_cartesian_jacobian(2, 0, 0)', lambda: spherical_to_cartesian_jacobian(2, 0, 0)),
    ]:
        try:
            print(shown, "=", call())
        except NotImplementedError:
            print(shown, "= not written yet (it raises NotImplementedError)")
    print("Then `grade ch03` grades the chapter.")
