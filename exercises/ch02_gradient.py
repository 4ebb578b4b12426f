"""Chapter 2: gradients.

The gradient of a scalar function f(x, y) collects its partial derivatives, one per input. It gives
the tangent plane f(a) + grad f(a) . (x - a), points uphill, and is perpendicular to the contour
(level curve) through the point.

The last two functions are the lesson's story of a local planner (chapter 2, "when to reach for
it"): a cost surface the lesson does not differentiate for you. Work its gradient out by hand.

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
    """The gradient of example_f: its partial derivatives with respect to x and to y, in that order.

    Work them out by hand (chapter 2, partial derivatives); the grader checks them exactly, so a
    finite difference of example_f is not enough.
    Arguments: x, y real numbers.
    Returns: a numpy array of shape (2,): (d f/d x, d f/d y).
    Example: example_gradient(1, 2) -> array([4., 1.])
    """
    raise NotImplementedError


def tangent_plane(f, grad, a, x):
    """The tangent-plane approximation of f at a, evaluated at x.

    Formula: f(a) + grad(a) . (x - a).
    Arguments: f a function of one vector returning a number; grad a function of one vector
    returning its gradient; a, x vectors of the same length (list, tuple or array).
    Returns: a float.
    Example: the lesson's f = x^2 + x y with a = (1, 2) and x = (1.1, 2.1); compare your estimate
    with the true value f(1.1, 2.1) = 3.52.
    """
    raise NotImplementedError


def bowl_gradient(x, y):
    """The gradient of the bowl g(x, y) = x^2 + 0.5 x y + y^2.

    Differentiate g by hand with respect to x and to y (the cross term depends on both).
    Arguments: x, y real numbers.
    Returns: a numpy array of shape (2,): (d g/d x, d g/d y).
    Example: bowl_gradient(1, 2) -> array([3., 4.5])
    """
    raise NotImplementedError


def contour_direction(x, y):
    """A unit vector tangent to the contour of g through (x, y).

    The contour is perpendicular to the gradient: turn bowl_gradient(x, y) by 90 degrees and
    scale it to length 1 (either orientation is accepted).
    Arguments: x, y real numbers.
    Returns: a numpy array of shape (2,) with length 1 and dot(result, bowl_gradient(x, y)) = 0.
    Raises: ValueError at (0, 0), where the gradient is zero and the direction is undefined.
    Example: contour_direction(1, 2) -> array([-0.8321, 0.5547]) (or its negative)
    """
    raise NotImplementedError


def planner_cost(x, y, obstacle):
    """A local planner's cost at the point (x, y): stay near the lane centre, keep away from the obstacle.

    Formula: c(x, y) = y^2 + 1 / d^2, where d^2 = (x - ox)^2 + (y - oy)^2 is the squared distance
    to the obstacle (ox, oy); the lane centre is the line y = 0.
    Arguments: x, y real numbers; obstacle a 2-vector (ox, oy) (list, tuple or array, possibly of ints).
    Returns: a float.
    Raises: ValueError at the obstacle itself (d = 0), and nowhere else.
    Example: planner_cost(0, 1, (2, 1)) -> 1.25
    """
    raise NotImplementedError


def planner_cost_gradient(x, y, obstacle):
    """The gradient of planner_cost with respect to the point (x, y), the obstacle held fixed.

    Derive it by hand (the obstacle term needs the chain rule); the grader compares it with finite
    differences of your planner_cost and checks that it is exact, near the obstacle too.
    Arguments: as planner_cost.
    Returns: a numpy array of shape (2,): (d c/d x, d c/d y).
    Raises: ValueError at the obstacle itself, and nowhere else.
    Example: planner_cost_gradient(0, 1, (2, 1)) -> array([0.25, 2.])
    """
    raise NotImplementedError


if __name__ == "__main__":  # python exercises/ch02_gradient.py: the worked example with your functions
    for shown, call in [
        ('example_f(1, 2)', lambda: example_f(1, 2)),
        ('example_gradient(1, 2)', lambda: example_gradient(1, 2)),
        ('planner_cost(0, 1, (2, 1))', lambda: planner_cost(0, 1, (2, 1))),
    ]:
        try:
            print(shown, "=", call())
        except NotImplementedError:
            print(shown, "= not written yet (it raises NotImplementedError)")
    print("Then `grade ch02` grades the chapter.")
