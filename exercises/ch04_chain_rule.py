"""Chapter 4: the chain rule in matrix form.

For a pipeline x -> u = f(x) -> g(u), the Jacobian of the whole is the product of the stages'
Jacobians, each evaluated at its own input: J(x) = Jg(f(x)) @ Jf(x). Order matters (the outer
stage on the left), and so does the evaluation point (Jg at u = f(x), not at x).

The lidar functions come from the lesson's lidar-to-world pipeline (chapter 4, "when to reach for
it"): a lidar return (r, theta) in the robot's frame becomes a point in the world frame. The lesson
does not work out its Jacobians: build them with the chain rule.

You may use your chapter 3 functions (polar_to_cartesian, polar_to_cartesian_jacobian): they are imported below,
in a form that works when graded, when run as a script and from a notebook in exercises/.
Run `grade ch04` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)

try:  # your chapter 3 functions; the three import forms grade alike
    from .ch03_jacobian import polar_to_cartesian, polar_to_cartesian_jacobian  # noqa: F401
except ImportError:  # run as a script, or imported from a notebook in exercises/
    from ch03_jacobian import polar_to_cartesian, polar_to_cartesian_jacobian  # noqa: F401


def g_stage(u):
    """The second stage of the pipeline.

    Formula: g(u) = (u1^2 + u2, u1 * u2).
    Arguments: u a 2-vector (list, tuple or array).
    Returns: a numpy array of shape (2,).
    Example: g_stage((2, 3)) -> array([7., 6.])
    """
    raise NotImplementedError


def g_jacobian(u):
    """The Jacobian of g_stage with respect to (u1, u2).

    Rows are the outputs of g, columns the inputs u1, u2. Differentiate by hand.
    Arguments: u a 2-vector.
    Returns: a numpy array of shape (2, 2).
    Example: g_jacobian((2, 3.4641)) -> [[4, 1], [3.4641, 2]]
    """
    raise NotImplementedError


def compose_jacobian(f, jac_f, jac_g, x):
    """The chain rule: the Jacobian of g(f(x)), from the Jacobians of the two stages.

    Formula: Jg(f(x)) @ Jf(x).
    Arguments: f a function of one vector returning a vector; jac_f, jac_g functions of one
    vector returning matrices; x a vector.
    Returns: a numpy array of shape (m, n).
    Example: with f = polar_to_cartesian (as a function of v = (r, theta)), jac_f its Jacobian,
    jac_g = g_jacobian and x = (4, pi/3) it gives pipeline_jacobian(4, pi/3).
    """
    raise NotImplementedError


def pipeline_jacobian(r, theta):
    """The Jacobian of g_stage(polar_to_cartesian(r, theta)) with respect to (r, theta).

    Use compose_jacobian with your chapter 3 functions and g_jacobian.
    Arguments: r, theta real numbers.
    Returns: a numpy array of shape (2, 2).
    Example: the grader checks it at the lesson's worked example, (r, theta) = (4, pi/3).
    """
    raise NotImplementedError


def lidar_to_world(r, theta, pose):
    """A lidar return in the world frame.

    The lidar sees a point at range r and angle theta in the robot's frame: polar_to_cartesian(r, theta).
    The robot stands at pose = (px, py, phi): turn that point by the heading phi (counter-clockwise,
    radians) and add the robot's position (px, py).
    Arguments: r, theta real numbers; pose a 3-vector (px, py, phi) (list, tuple or array).
    Returns: a numpy array of shape (2,): the world (x, y).
    Example: lidar_to_world(1, 0, (1, 2, pi/2)) -> array([1., 3.])
    """
    raise NotImplementedError


def lidar_to_world_jacobian(r, theta, pose):
    """The Jacobian of lidar_to_world with respect to the return (r, theta), the pose held fixed.

    Rows are the world (x, y), columns (r, theta). The pipeline has two stages, the polar map and
    the rotation-plus-translation: chain their Jacobians. The grader compares the result with finite
    differences of your lidar_to_world and checks that it is exact. Graded at r >= 0.3.
    Arguments: as lidar_to_world.
    Returns: a numpy array of shape (2, 2).
    Example: lidar_to_world_jacobian(1, 0, (1, 2, pi/2)) -> [[0, -1], [1, 0]]
    """
    raise NotImplementedError


def lidar_pose_jacobian(r, theta, pose):
    """The Jacobian of lidar_to_world with respect to the pose (px, py, phi), the return held fixed.

    Rows are the world (x, y), columns (px, py, phi): how the world point moves when the robot's
    position or heading is uncertain. Derive it by hand; the grader compares it with finite
    differences of your lidar_to_world and checks that it is exact.
    Arguments: as lidar_to_world.
    Returns: a numpy array of shape (2, 3).
    Example: lidar_pose_jacobian(1, 0, (1, 2, pi/2)) -> [[1, 0, -1], [0, 1, 0]]
    """
    raise NotImplementedError


if __name__ == "__main__":  # python exercises/ch04_chain_rule.py: the worked example with your functions
    for shown, call in [
        ('g_jacobian((2, 3.4641))', lambda: g_jacobian((2, 3.4641))),
        ('pipeline_jacobian(4, np.pi / 3)', lambda: pipeline_jacobian(4, np.pi / 3)),
        ('lidar_to_world(1, 0, (1, 2, np.pi / 2))', lambda: lidar_to_world(1, 0, (1, 2, np.pi / 2))),
    ]:
        try:
            print(shown, "=", call())
        except NotImplementedError:
            print(shown, "= not written yet (it raises NotImplementedError)")
    print("Then `grade ch04` grades the chapter.")
