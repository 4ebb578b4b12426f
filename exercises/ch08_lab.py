"""Chapter 8: the linearization lab.

Push a Monte Carlo cloud of positions through the range-bearing sensor and compare its sample
covariance with the linearized ellipse H (sigma^2 I) H^T. Far from the dish they agree; close to
it the bearing is too nonlinear and the linearization fails. Then use H for one EKF update.

You may use your chapter 6 functions (range_bearing, H_jacobian): they are imported below,
in a form that works when graded, when run as a script and from a notebook in exercises/.
Run `grade ch08` to check your work.
"""

import numpy as np  # noqa: F401  (for you to use)

try:  # your chapter 6 functions; the three import forms grade alike
    from .ch06_measurement import range_bearing, H_jacobian  # noqa: F401
except ImportError:  # run as a script, or imported from a notebook in exercises/
    from ch06_measurement import range_bearing, H_jacobian  # noqa: F401


def sample_positions(mean, sigma, n, rng):
    """n samples of N(mean, sigma^2 I) drawn from the numpy Generator rng.

    Formula: mean + sigma * rng.standard_normal((n, 2)).
    Arguments: mean a 2-vector; sigma a float; n an int; rng a np.random.Generator.
    Returns: a numpy array of shape (n, 2).
    Example: sample_positions((3, 4), 0.8, 5, np.random.default_rng(0)) -> 5 x 2 array near (3, 4)
    """
    raise NotImplementedError


def measure_samples(samples, ref_bearing):
    """(range, bearing) of each sample, bearings unwrapped around ref_bearing.

    Each bearing b = atan2(y, x) is moved by whole turns to lie within pi of ref_bearing:
    b + 2 pi round((ref_bearing - b) / (2 pi)), so a cloud straddling +-pi stays in one piece.
    Arguments: samples an n x 2 array; ref_bearing a float.
    Returns: a numpy array of shape (n, 2).
    Example: measure_samples([[3, 4], [-1, -0.01]], 3.1) -> [[5, 0.9273], [1.00005, 3.1516]]
    """
    raise NotImplementedError


def linearized_measurement_cov(x, y, sigma):
    """The linearized measurement covariance H Sigma H^T at the operating point, Sigma = sigma^2 I.

    Arguments: x, y the operating point; sigma the position standard deviation.
    Returns: a numpy array of shape (2, 2).
    Example: linearized_measurement_cov(3, 4, 0.8) -> diag(0.64, 0.0256)
    """
    raise NotImplementedError


def sample_covariance(z):
    """The unbiased 2 x 2 sample covariance of an n x 2 array (n >= 2): divide by n - 1.

    Arguments: z an n x 2 array.
    Returns: a numpy array of shape (2, 2), equal to np.cov(z.T).
    Example: sample_covariance([[0, 0], [1, 3], [2, 0]]) -> [[1, 0], [0, 3]]
    """
    raise NotImplementedError


def linearization_mismatch(x, y, sigma, n, seed):
    """How badly the linearized ellipse describes the real measurement cloud.

    Draw n positions around (x, y) with sample_positions and rng = np.random.default_rng(seed),
    measure them with bearings unwrapped around atan2(y, x), and return the relative error
    norm(S_mc - S_lin) / norm(S_lin) (Frobenius norms) between their sample covariance S_mc and
    the linearized S_lin.
    Arguments: x, y the operating point; sigma; n; seed an int.
    Returns: a float.
    Example: sigma 0.8, n 5000: about 0.02 at (3, 4) (always < 0.1), about 0.55 at (0.3, 0.2) (> 0.4)
    """
    raise NotImplementedError


def ekf_update(x, P, z, R):
    """One EKF measurement update of a 2-D position with the range-bearing sensor.

    Steps: predicted measurement h = range_bearing(x); H = H_jacobian(x);
    innovation y = z - h with its bearing wrapped to [-pi, pi); S = H P H^T + R;
    K = P H^T S^-1; x_new = x + K y; P_new = (I - K H) P (or the Joseph form
    (I - K H) P (I - K H)^T + K R K^T).
    Arguments: x a 2-vector; P a 2 x 2 covariance; z a measured (range, bearing); R its 2 x 2
    covariance.
    Returns: the tuple (x_new, P_new) of numpy arrays of shapes (2,) and (2, 2).
    Raises: ValueError at r = 0.
    Example: ekf_update((3, 4), 0.1 I, (5.1, 0.93), diag(0.01, 0.001))
             -> x_new = (3.0459, 4.0792), P_new = [[0.01607, -0.00524], [-0.00524, 0.01302]]
    """
    raise NotImplementedError


if __name__ == "__main__":  # python exercises/ch08_lab.py: the worked example with your functions
    for shown, call in [
        ('linearized_measurement_cov(3, 4, 0.8)', lambda: linearized_measurement_cov(3, 4, 0.8)),
        ('linearization_mismatch(3, 4, 0.8, 5000, 0)', lambda: linearization_mismatch(3, 4, 0.8, 5000, 0)),
    ]:
        try:
            print(shown, "=", call())
        except NotImplementedError:
            print(shown, "= not written yet (it raises NotImplementedError)")
    print("Then `grade ch08` grades the chapter.")
