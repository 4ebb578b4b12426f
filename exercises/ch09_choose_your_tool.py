"""Chapter 9: choose your tool.

One output and many inputs: the gradient. Many outputs: the Jacobian. Curvature of a scalar
function: the Hessian (the Jacobian of the gradient), whose eigenvalues classify a critical point.
No formula at hand, or checking a hand-derived one: finite differences.

You may use your chapter 5 functions (jacobian_fd): they are imported below,
in a form that works when graded, when run as a script and from a notebook in exercises/.
Run `grade ch09` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)

try:  # your chapter 5 functions; the three import forms grade alike
    from .ch05_finite_differences import jacobian_fd  # noqa: F401
except ImportError:  # run as a script, or imported from a notebook in exercises/
    from ch05_finite_differences import jacobian_fd  # noqa: F401


def gradient_fd(f, x, h=1e-5):
    """Central-difference gradient of a scalar function f of a vector x.

    Component j: (f(x + h e_j) - f(x - h e_j)) / (2 h). Convert x to float first (an integer
    array plus 1e-5 stays an integer array otherwise).
    Arguments: f a function of one vector returning a number; x a vector; h the step.
    Returns: a numpy array of shape (n,).
    Example: gradient_fd(lambda v: v[0]**2 + v[0]*v[1], [1, 2]) -> array([4., 1.])
    """
    raise NotImplementedError


def hessian_fd(f, x, h=1e-4):
    """The n x n Hessian of f as the Jacobian of its gradient, symmetrised.

    Idea: the Hessian is the Jacobian of the gradient: difference your gradient_fd the way chapter 5's
    jacobian_fd differences a vector function (both with step h), then symmetrise, (H + H^T) / 2.
    Arguments: f a scalar function of one vector; x a vector; h the step.
    Returns: a numpy array of shape (n, n), symmetric.
    Example: hessian_fd(lambda v: v[0]**2 + v[0]*v[1], (1, 2)) -> [[2, 1], [1, 0]]
    """
    raise NotImplementedError


def classify_critical_point(hessian):
    """Classify a critical point from its Hessian.

    Symmetrise, take the eigenvalues, treat an eigenvalue as zero when its size is at most
    1e-8 * max(1, largest size). "saddle" whenever both signs occur; otherwise "minimum" (all > 0),
    "maximum" (all < 0) or "degenerate" (some zero).
    Arguments: hessian an n x n array.
    Returns: one of the strings "saddle", "minimum", "maximum", "degenerate".
    Example: classify_critical_point([[2, 1], [1, 0]]) -> "saddle"
    """
    raise NotImplementedError


if __name__ == "__main__":  # python exercises/ch09_choose_your_tool.py: the worked example with your functions
    for shown, call in [
        ('hessian_fd(lambda v: v[0] ** 2 + v[0] * v[1], (1, 2))',
         lambda: hessian_fd(lambda v: v[0] ** 2 + v[0] * v[1], (1, 2))),
        ('classify_critical_point(np.array([[2.0, 1.0], [1.0, 0.0]]))',
         lambda: classify_critical_point(np.array([[2.0, 1.0], [1.0, 0.0]]))),
    ]:
        try:
            print(shown, "=", call())
        except NotImplementedError:
            print(shown, "= not written yet (it raises NotImplementedError)")
    print("Then `grade ch09` grades the chapter.")
