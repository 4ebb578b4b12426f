"""Chapter 1: tangent lines.

Near a point a, a smooth function is close to its tangent line L(x) = f(a) + f'(a)(x - a).
The error |f(x) - L(x)| grows like delta^2 with delta = x - a (about 0.5 |f''(a)| delta^2):
double the distance, quadruple the error.

The grader passes you plain Python functions f, fprime, fsecond that work elementwise on numpy
arrays (for example np.sqrt and its derivatives). Run `grade ch01` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)


def tangent_line(f, fprime, a, x):
    """The tangent line of f at a, evaluated at x.

    Formula: L(x) = f(a) + f'(a) (x - a).
    Arguments: f, fprime functions of one number (elementwise on arrays); a a float;
    x a float or a 1-D numpy array.
    Returns: a float when x is a float, an array of x's shape when x is an array.
    Example: with f = np.sqrt at a = 4 (f(4) = 2, f'(4) = 0.25): tangent_line(..., 4, 5) -> 2.25
    """
    raise NotImplementedError


def linearization_error(f, fprime, a, x):
    """How far the tangent line at a is from f at x.

    Formula: |f(x) - L(x)| with L the tangent line at a.
    Arguments: as tangent_line.
    Returns: a float, or an array of x's shape.
    Example: f = np.sqrt, a = 4, x = [4.5, 5, 6, 8] -> [0.003680, 0.013932, 0.050510, 0.171573]
    """
    raise NotImplementedError


def taylor_error_estimate(fsecond, a, delta):
    """The second-order estimate of the tangent line's error a distance delta from a.

    Formula: 0.5 * |f''(a)| * delta^2.
    Arguments: fsecond the second derivative (a function of one number); a a float; delta a float.
    Returns: a float.
    Example: f = sqrt (the grader passes its second derivative as fsecond), a = 4, delta = 1 -> 0.015625
    """
    raise NotImplementedError


if __name__ == "__main__":  # python exercises/ch01_tangent_line.py: the worked example with your functions
    for shown, call in [
        ('tangent_line(np.sqrt, lambda x: 0.5 / np.sqrt(x), 4.0, 5.0)',
         lambda: tangent_line(np.sqrt, lambda x: 0.5 / np.sqrt(x), 4.0, 5.0)),
        ('linearization_error(np.sqrt, lambda x: 0.5 / np.sqrt(x), 4.0, np.array([4.5, 5, 6, 8]))',
         lambda: linearization_error(np.sqrt, lambda x: 0.5 / np.sqrt(x), 4.0, np.array([4.5, 5, 6, 8]))),
        ('taylor_error_estimate(lambda x: -0.25 * x ** -1.5, 4.0, 1.0)',
         lambda: taylor_error_estimate(lambda x: -0.25 * x ** -1.5, 4.0, 1.0)),
    ]:
        try:
            print(shown, "=", call())
        except NotImplementedError:
            print(shown, "= not written yet (it raises NotImplementedError)")
    print("Then `grade ch01` grades the chapter.")
