"""Chapter 2: gradients.

The gradient of a scalar function f(x, y) collects its partial derivatives, grad f = (df/dx,
df/dy). It gives the tangent plane f(a) + grad f(a) . (x - a), points uphill, and is perpendicular
to the contour (level curve) through the point.

Run `grade ch02` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)


def example_f(x, y):
    """The lesson's example function.

    Formula: f(x, y) = x^2 + x y.
    Arguments: x, y real numbers.
    Returns: a float.
    Example: example_f(1, 2) -> 3.0
    """
    raise NotImplementedError


def example_gradient(x, y):
    """The gradient of f(x, y) = x^2 + x y.

    Formula: grad f = (df/dx, df/dy) = (2x + y, x).
    Arguments: x, y real numbers.
    Returns: a numpy array of shape (2,).
    Example: example_gradient(1, 2) -> array([4., 1.])
    """
    raise NotImplementedError


def tangent_plane(f, grad, a, x):
    """The tangent-plane approximation of f at a, evaluated at x.

    Formula: f(a) + grad(a) . (x - a).
    Arguments: f a function of one vector returning a number; grad a function of one vector
    returning its gradient; a, x 2-vectors (list, tuple or array).
    Returns: a float.
    Example: f = x^2 + xy, a = (1, 2), x = (1.1, 2.1) -> 3 + (4, 1) . (0.1, 0.1) = 3.50
    (the true value is 3.52).
    """
    raise NotImplementedError


def bowl_gradient(x, y):
    """The gradient of the bowl g(x, y) = x^2 + 0.5 x y + y^2.

    Formula: (2x + 0.5y, 0.5x + 2y).
    Arguments: x, y real numbers.
    Returns: a numpy array of shape (2,).
    Example: bowl_gradient(1, 2) -> array([3., 4.5])
    """
    raise NotImplementedError


def contour_direction(x, y):
    """A unit vector tangent to the contour of g through (x, y).

    The contour is perpendicular to the gradient, so turn bowl_gradient by 90 degrees and
    normalise: (-gy, gx) / |grad g| (either orientation is accepted).
    Arguments: x, y real numbers.
    Returns: a numpy array of shape (2,) with length 1 and dot(result, bowl_gradient(x, y)) = 0.
    Raises: ValueError at (0, 0), where the gradient is zero and the direction is undefined.
    Example: contour_direction(1, 2) -> array([-0.8321, 0.5547]) (or its negative)
    """
    raise NotImplementedError
