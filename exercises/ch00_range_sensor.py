"""Chapter 0: the range-sensor problem.

A dish at the origin measures the range r = sqrt(x^2 + y^2) to a drone at (x, y). The range is
not a linear function of the position: no fixed matrix H gives range = H [x, y], superposition
fails, and pushing a Gaussian cloud of positions through the sensor moves the mean range outward.
This is why the rest of the lesson linearizes.

Run `grade ch00` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)


def range_reading(x, y):
    """The range from the dish at the origin to the point (x, y).

    Formula: r = sqrt(x^2 + y^2).
    Arguments: x, y real numbers (int or float).
    Returns: a float.
    Example: range_reading(3, 4) -> 5.0
    """
    raise NotImplementedError


def superposition_gap(p, q):
    """How far the range sensor is from being linear: range(p + q) - (range(p) + range(q)).

    A linear sensor z = H p would give exactly 0 for every p, q; a nonzero gap shows that no
    fixed matrix H can describe the range.
    Arguments: p, q 2-vectors (list, tuple or 1-D numpy array, possibly of ints).
    Returns: a float.
    Example: superposition_gap((3, 0), (0, 4)) -> 5 - (3 + 4) = -2.0
    """
    raise NotImplementedError


def mean_shift(mean, sigma, n, seed):
    """Mean range of a Gaussian cloud of positions minus the range of the cloud's mean.

    Draw n positions from N(mean, sigma^2 I) with rng = np.random.default_rng(seed) as
    mean + sigma * rng.standard_normal((n, 2)), take the range of each, average, and subtract
    range(mean).
    Arguments: mean a 2-vector, sigma > 0 a float, n an int, seed an int.
    Returns: a float (positive: the cloud's mean range moves outward).
    Example: mean_shift((3, 4), 1.0, 100000, seed) -> about 0.10
    """
    raise NotImplementedError


if __name__ == "__main__":  # python exercises/ch00_range_sensor.py: the worked example with your functions
    for shown, call in [
        ('range_reading(3, 4)', lambda: range_reading(3, 4)),
        ('superposition_gap((3, 0), (0, 4))', lambda: superposition_gap((3, 0), (0, 4))),
        ('mean_shift((3, 4), 1.0, 100000, 0)', lambda: mean_shift((3, 4), 1.0, 100000, 0)),
    ]:
        try:
            print(shown, "=", call())
        except NotImplementedError:
            print(shown, "= not written yet (it raises NotImplementedError)")
    print("Then `grade ch00` grades the chapter.")
