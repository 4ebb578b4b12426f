"""Formulas learners confuse with the right one (grader.checks.confusions and the checks' own slips), each named
in a learner's words on a submission that makes it, ahead of any generated slip or category."""

from __future__ import annotations

import pytest

from grader.model import Status
from tests.support import build_submission, grade_code, replace_function

# (module, function, the learner's code, the check, the mistake, the start of its sentence)
CONFUSED = {
    "taxicab range": ("ch00_range_sensor", "range_reading", """
        def range_reading(x, y):
            return float(abs(x) + abs(y))
        """, "range_reading_worked_example", "taxicab range",
        "the range is |x| + |y|, the taxicab distance: it is the straight-line distance, sqrt(x^2 + y^2)."),
    "atan plus pi everywhere": ("ch06_measurement", "range_bearing", """
        def range_bearing(x, y):
            return np.array([np.hypot(x, y), np.arctan(y / x) + np.pi])
        """, "range_bearing_all_quadrants", "atan plus pi", "the bearing is atan(y/x) + pi: off by pi where x > 0"),
    "taxicab range in 3-D": ("ch06_measurement", "range_bearing_elevation", """
        def range_bearing_elevation(x, y, z):
            return np.array([abs(x) + abs(y) + abs(z), np.arctan2(y, x), np.arctan2(z, np.hypot(x, y))])
        """, "range_bearing_elevation_random_points", "taxicab range", "the range is |x| + |y|, |z|, the taxicab"),
    "backward for forward": ("ch05_finite_differences", "forward_difference", """
        def forward_difference(f, x, h):
            return (f(x) - f(x - h)) / h
        """, "forward_difference_random_inputs", "backward difference",
        "that is the backward difference (f(x) - f(x-h))/h: the forward one is (f(x+h) - f(x))/h."),
    "precedence": ("ch05_finite_differences", "central_difference", """
        def central_difference(f, x, h):
            return (f(x + h) - f(x - h)) / 2 * h
        """, "central_difference_worked_example", "precedence", "/ 2 * h multiplies by h"),
    "R as a standard deviation": ("ch08_lab", "ekf_update", """
        def ekf_update(x, P, z, R):
            x, P, z, R = (np.asarray(a, dtype=float) for a in (x, P, z, R))
            H = H_jacobian(x[0], x[1])
            nu = z - range_bearing(x[0], x[1])
            nu[1] = (nu[1] + np.pi) % (2 * np.pi) - np.pi
            S = H @ P @ H.T + R @ R
            K = P @ H.T @ np.linalg.inv(S)
            return x + K @ nu, (np.eye(2) - K @ H) @ P
        """, "ekf_update_random_states", "R as a standard deviation", "R is squared in the innovation covariance"),
    "innovation wrapped with % 2 pi": ("ch08_lab", "ekf_update", """
        def ekf_update(x, P, z, R):
            x, P, z, R = (np.asarray(a, dtype=float) for a in (x, P, z, R))
            H = H_jacobian(x[0], x[1])
            nu = z - range_bearing(x[0], x[1])
            nu[1] = nu[1] % (2 * np.pi)
            K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
            return x + K @ nu, (np.eye(2) - K @ H) @ P
        """, "ekf_update_wraps_bearing_innovation", "innovation wrapped into [0, 2 pi)",
        "the bearing innovation is wrapped with % (2 pi), into [0, 2 pi)"),
    "classification without a tolerance": ("ch09_choose_your_tool", "classify_critical_point", """
        def classify_critical_point(hessian):
            A = np.asarray(hessian, dtype=float)
            values = np.linalg.eigvalsh(0.5 * (A + A.T))
            if np.any(values > 0) and np.any(values < 0):
                return "saddle"
            if np.all(values > 0):
                return "minimum"
            if np.all(values < 0):
                return "maximum"
            return "degenerate"
        """, "classify_zero_threshold", "no tolerance", "an eigenvalue is compared with 0 exactly"),
    "F P": ("ch07_dynamics", "propagate_covariance", """
        def propagate_covariance(P, F, Q=None):
            out = np.asarray(F, dtype=float) @ np.asarray(P, dtype=float)
            return out if Q is None else out + np.asarray(Q, dtype=float)
        """, "propagate_random_matrices", "F P", "your result is F P"),
    "uncentred covariance": ("ch08_lab", "sample_covariance", """
        def sample_covariance(z):
            z = np.asarray(z, dtype=float)
            return z.T @ z / (len(z) - 1)
        """, "sample_covariance_matches_np_cov", "mean not subtracted", "the mean is not subtracted"),
    "sin and cos swapped in the motion": ("ch07_dynamics", "motion_model", """
        def motion_model(state, v, omega, dt):
            x, y, th = np.asarray(state, dtype=float)
            return np.array([x + v * np.sin(th) * dt, y + v * np.cos(th) * dt, th + omega * dt])
        """, "motion_model_random_inputs", "sin and cos swapped", "x moves with sin(theta) and y with cos(theta)"),
    "determinant with a plus": ("ch03_jacobian", "area_scale", """
        def area_scale(r, theta):
            J = polar_to_cartesian_jacobian(r, theta)
            return float(J[0, 0] * J[1, 1] + J[0, 1] * J[1, 0])
        """, "area_scale_is_r", "determinant with a plus", "the determinant of [[a, b], [c, d]] is a d - b c"),
}


@pytest.mark.parametrize("name", list(CONFUSED))
def test_a_confused_formula_is_named(tmp_path, name):
    module, function, source, check_id, mistake, sentence = CONFUSED[name]
    root = build_submission(tmp_path / "slip", {module: replace_function(module, function, source)})
    checks = {c.id: c for c in grade_code(root, [module[:4]]).chapters[0].checks}
    check = checks[check_id]
    assert check.status == Status.FAIL, check.message
    assert (check.mistake, check.help[:len(sentence)]) == (mistake, sentence), check.message
    wrong = [c for c in checks.values() if c.function == function and c.status == Status.FAIL and c.mistake
             and c.mistake != mistake]
    assert not [(c.id, c.mistake) for c in wrong if c.help in ("one sign is wrong.",
                                                               "this takes the smallest value where the largest "
                                                               "value belongs.")]
