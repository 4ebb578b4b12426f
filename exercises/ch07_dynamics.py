"""Chapter 7: the motion-model Jacobian F and covariance propagation.

A robot at state (x, y, theta) driving at speed v and turning at rate omega for dt moves to
(x + v cos(theta) dt, y + v sin(theta) dt, theta + omega dt). Its Jacobian F = d(new state)/d(state)
carries the uncertainty forward: P_new = F P F^T (+ Q).

The bicycle functions come from the lesson's car story (chapter 7, "when to reach for it"): a
steered car, whose noisy controls add the process noise Q. The lesson does not work out their
Jacobian: derive it.

Run `grade ch07` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)


def motion_model(state, v, omega, dt):
    """One step of the unicycle motion model.

    Formula: (x + v cos(theta) dt, y + v sin(theta) dt, theta + omega dt).
    Arguments: state a 3-vector (x, y, theta); v, omega, dt floats.
    Returns: a numpy array of shape (3,).
    Example: motion_model((0, 0, pi/6), 2.0, 0.5, 0.1) -> array([0.1732, 0.1, 0.5736])
    """
    raise NotImplementedError


def F_jacobian(state, v, omega, dt):
    """The Jacobian of motion_model with respect to the state (x, y, theta); v, omega, dt held fixed.

    Rows are the new state (x', y', theta'), columns the old (x, y, theta). Differentiate by hand;
    the grader checks the result exactly.
    Arguments: as motion_model.
    Returns: a numpy array of shape (3, 3).
    Example: state (0, 0, pi/6), v = 2, omega = 0.5, dt = 0.1 -> F[0, 2] = -0.1, F[1, 2] = 0.1732
    """
    raise NotImplementedError


def propagate_covariance(P, F, Q=None):
    """Carry a covariance through a linearized step.

    Formula: F P F^T, plus Q when Q is given.
    Arguments: P an n x n covariance; F an n x n Jacobian; Q None or an n x n process noise.
    Returns: a numpy array of shape (n, n), symmetric positive semi-definite.
    Example: the grader checks it at the lesson's P = diag(0.04, 0.04, 0.01) with the F of
    F_jacobian's example.
    """
    raise NotImplementedError


def bicycle_model(state, v, steer, wheelbase, dt):
    """One step of the kinematic bicycle model: a car steered by its front wheels.

    Formula: (x + v cos(theta) dt, y + v sin(theta) dt, theta + v tan(steer) / wheelbase * dt).
    Arguments: state a 3-vector (x, y, theta); v the speed; steer the steering angle (radians);
    wheelbase > 0; dt the time step.
    Returns: a numpy array of shape (3,).
    Example: bicycle_model((0, 0, 0), 2.0, 0.0, 1.0, 0.1) -> array([0.2, 0., 0.])
    """
    raise NotImplementedError


def bicycle_control_jacobian(state, v, steer, wheelbase, dt):
    """The Jacobian of bicycle_model with respect to the controls (v, steer); the state held fixed.

    Rows are the new state (x', y', theta'), columns the controls (v, steer). Derive it by hand; the
    grader compares it with finite differences of your bicycle_model and checks that it is exact.
    Graded at |steer| <= 1.
    Arguments: as bicycle_model.
    Returns: a numpy array of shape (3, 2).
    Example: bicycle_control_jacobian((0, 0, 0), 2.0, 0.0, 1.0, 0.1) -> [[0.1, 0], [0, 0], [0, 0.2]]
    """
    raise NotImplementedError


def control_noise_covariance(state, v, steer, wheelbase, dt, sigma_v, sigma_steer):
    """The process noise Q that noisy controls add in one step.

    Formula: V diag(sigma_v^2, sigma_steer^2) V^T, with V the control Jacobian at these arguments (as
    bicycle_control_jacobian gives it): independent noise of standard deviation sigma_v on the speed
    and sigma_steer on the steering angle, carried into the state.
    Arguments: as bicycle_model, plus sigma_v, sigma_steer >= 0.
    Returns: a numpy array of shape (3, 3), symmetric positive semi-definite.
    Example: at the point of bicycle_control_jacobian's example with sigma_v = 0.5 and
    sigma_steer = 0.1, only the entries [0, 0] and [2, 2] are nonzero.
    """
    raise NotImplementedError


if __name__ == "__main__":  # python exercises/ch07_dynamics.py: the worked example with your functions
    for shown, call in [
        ('motion_model((0, 0, np.pi / 6), 2, 0.5, 0.1)',
         lambda: motion_model((0, 0, np.pi / 6), 2, 0.5, 0.1)),
        ('F_jacobian((0, 0, np.pi / 6), 2, 0.5, 0.1)', lambda: F_jacobian((0, 0, np.pi / 6), 2, 0.5, 0.1)),
        ('bicycle_control_jacobian((0, 0, 0), 2, 0, 1, 0.1)',
         lambda: bicycle_control_jacobian((0, 0, 0), 2, 0, 1, 0.1)),
    ]:
        try:
            print(shown, "=", call())
        except NotImplementedError:
            print(shown, "= not written yet (it raises NotImplementedError)")
    print("Then `grade ch07` grades the chapter.")
