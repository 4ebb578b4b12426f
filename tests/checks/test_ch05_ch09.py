"""The checks of chapters 5, 7, 8 and 9 through the real grader and real child processes: the
reference solutions get full marks, the stubs get zero, and each realistic mistake fails the check
aimed at it while the other functions still pass."""

from __future__ import annotations

import numpy as np
import pytest

import solutions.ch08_lab as ch08_ref
from grader import checks as check_registry
from grader.chapters import BY_ID
from grader.checks import ch05, ch08, ch09
from grader.model import Status
from tests.support import (
    BEYOND_THE_WORKED_EXAMPLES,
    checks_by_id,
    first_of_each,
    grade_code,
    replace_function,
)

CHAPTERS = ["ch05", "ch07", "ch08", "ch09"]
MODULES = {c: BY_ID[c].module for c in CHAPTERS}


def test_chapter_sizes_follow_the_guide():
    """The worked examples' functions keep the guide's size; the maps beyond them and the exact-derivative
    checks come on top, up to 6 points per map."""
    for chapter_id in CHAPTERS:
        chapter = check_registry.load(chapter_id)
        beyond = BEYOND_THE_WORKED_EXAMPLES.get(chapter_id, ())
        worked = [c for c in chapter.checks if c.function not in beyond and not c.exact_derivative]
        assert 10 <= sum(c.points for c in worked) <= 18, chapter_id
        assert sum(c.points for c in chapter.checks if c.function in beyond) <= 6 * len(beyond), chapter_id
        assert all(1 <= c.points <= 2 for c in chapter.checks), chapter_id
        assert {c.function for c in chapter.checks} >= set(FUNCTIONS[chapter_id]), chapter_id


FUNCTIONS = {
    "ch05": ["forward_difference", "central_difference", "jacobian_fd", "max_jacobian_error", "best_step"],
    "ch07": ["motion_model", "F_jacobian", "propagate_covariance"],
    "ch08": ["sample_positions", "measure_samples", "linearized_measurement_cov", "sample_covariance",
             "linearization_mismatch", "ekf_update"],
    "ch09": ["gradient_fd", "hessian_fd", "classify_critical_point"],
}


# ------------------------------------------------------------------ the tolerances, in this process

def test_difference_bounds_hold_for_right_answers_and_separate_the_wrong_ones():
    from solutions.oracle import ch05 as oracle

    rng = np.random.default_rng(5)
    for _ in range(300):
        for name, x, h in ch05._scalar_cases(rng):
            f = oracle.SCALAR[name][0][0]
            law = oracle.difference_law(name, x, h)
            exact = law["exact"]
            central = (f(x + h) - f(x - h)) / (2 * h) - exact
            forward = (f(x + h) - f(x)) / h - exact
            backward = (f(x) - f(x - h)) / h - exact
            low, high = law["central"]
            assert low <= central <= high
            assert not low <= forward <= high and not low <= backward <= high
            low, high = law["forward"]
            assert low <= forward <= high
            assert not low <= central <= high and not low <= backward <= high


def test_hessian_tolerance_covers_the_reference_and_not_a_forward_outer_difference():
    from grader.catalogue import CALLABLES
    from solutions.ch09_choose_your_tool import gradient_fd, hessian_fd
    from solutions.oracle import ch09 as oracle

    rng = np.random.default_rng(3)
    for _ in range(40):
        for name in ("saddle3_vec", "rosenbrock_vec", "wave_vec"):
            p = ch09._point(rng, name)
            f = CALLABLES[name]
            tol = oracle.hessian_tolerance(name, p, 1e-4)
            exact = oracle.hessian_of(name, p)
            assert np.max(np.abs(hessian_fd(f, p) - exact)) <= tol
            g0 = gradient_fd(f, p, 1e-4)
            outer = np.stack([(gradient_fd(f, p + 1e-4 * e, 1e-4) - g0) / 1e-4 for e in np.eye(p.size)], axis=1)
            assert np.max(np.abs(0.5 * (outer + outer.T) - exact)) > 3 * tol


def test_mismatch_simulation_matches_the_reference_over_seeds():
    from solutions.oracle.ch08 import mismatch_distribution

    for x, y, sigma, n in [(-3.0, 0.2, 0.8, 5000), (0.5, 0.3, 0.8, 5000)]:
        mean, spread = mismatch_distribution(x, y, sigma, n)
        values = np.array([ch08_ref.linearization_mismatch(x, y, sigma, n, seed) for seed in range(40)])
        assert abs(values.mean() - mean) < 4 * spread / np.sqrt(40) + 0.1 * spread
        assert 0.6 < values.std() / spread < 1.6
        assert np.all(np.abs(values - mean) < ch08.SPREAD * spread)


# ------------------------------------------------------------------ realistic mistakes

# (chapter, function, wrong source, the check aimed at it, words its message must contain,
#  checks of other functions that use the wrong one and so may fail with it)
MUTANTS = {
    # ---------------------------------------------------------------- ch05
    "central is really forward": ("ch05", "central_difference", """
        def central_difference(f, x, h):
            return float((f(x + h) - f(x)) / h)
        """, "central_difference_random_inputs", ["That is the forward difference", "h^2/6 f'''"],
        {"best_step_worked_example", "best_step_random_inputs"}),
    "central divides by h": ("ch05", "central_difference", """
        def central_difference(f, x, h):
            return float((f(x + h) - f(x - h)) / h)
        """, "central_difference_worked_example", ["central_difference(sin, 1, 1e-05): got 1.0806"],
        {"best_step_worked_example", "best_step_random_inputs"}),
    "forward is really central": ("ch05", "forward_difference", """
        def forward_difference(f, x, h):
            return float((f(x + h) - f(x - h)) / (2 * h))
        """, "forward_difference_error_is_order_h", ["log-log slope of 2", "h^1"], set()),
    "forward is really backward": ("ch05", "forward_difference", """
        def forward_difference(f, x, h):
            return float((f(x) - f(x - h)) / h)
        """, "forward_difference_random_inputs", ["h/2 f''(c)", "must be in ["], set()),
    "jacobian_fd transposed": ("ch05", "jacobian_fd", """
        def jacobian_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            rows = []
            for j in range(x.size):
                e = np.zeros_like(x)
                e[j] = h
                rows.append((np.asarray(f(x + e), dtype=float) - np.asarray(f(x - e), dtype=float)) / (2 * h))
            return np.array(rows)
        """, "jacobian_fd_worked_example", ["J[0,1] = d x/d theta: got 0.866025, expected -3.4641"],
        {"max_jacobian_error_right_jacobian", "max_jacobian_error_wrong_jacobian"}),
    "jacobian_fd keeps integer x": ("ch05", "jacobian_fd", """
        def jacobian_fd(f, x, h=1e-5):
            x = np.asarray(x)
            columns = []
            for j in range(x.size):
                e = np.zeros_like(x)
                e[j] = h
                columns.append((np.asarray(f(x + e), dtype=float) - np.asarray(f(x - e), dtype=float)) / (2 * h))
            return np.stack(columns, axis=1)
        """, "jacobian_fd_random_inputs", ["np.array((2, -3), int)", "got 0"], set()),
    "jacobian_fd forward difference": ("ch05", "jacobian_fd", """
        def jacobian_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            base = np.asarray(f(x), dtype=float)
            columns = []
            for j in range(x.size):
                e = np.zeros_like(x)
                e[j] = h
                columns.append((np.asarray(f(x + e), dtype=float) - base) / h)
            return np.stack(columns, axis=1)
        """, "jacobian_fd_random_inputs", ["jacobian_fd(", "entries differ"],
        {"max_jacobian_error_right_jacobian", "max_jacobian_error_wrong_jacobian"}),
    "Jacobian check without abs": ("ch05", "max_jacobian_error", """
        def max_jacobian_error(jac, f, x, h=1e-5):
            analytic = np.asarray(jac(np.asarray(x, dtype=float)), dtype=float)
            return float(np.max(analytic - jacobian_fd(f, x, h)))
        """, "max_jacobian_error_wrong_jacobian", ["max_jacobian_error(mix_jac_sign_slip, mix_vec, ("], set()),
    "Jacobian check as a norm": ("ch05", "max_jacobian_error", """
        def max_jacobian_error(jac, f, x, h=1e-5):
            analytic = np.asarray(jac(np.asarray(x, dtype=float)), dtype=float)
            return float(np.linalg.norm(analytic - jacobian_fd(f, x, h)))
        """, "max_jacobian_error_wrong_jacobian", ["max_jacobian_error(twist_jac_transposed"], set()),
    "best step by forward differences": ("ch05", "best_step", """
        def best_step(f, fprime, x, hs):
            errors = [abs(forward_difference(f, x, h) - fprime(x)) for h in hs]
            return float(list(hs)[int(np.argmin(errors))])
        """, "best_step_worked_example", ["within 10x of the smallest error", "returned h = 1e-08"], set()),
    "best step returns the index": ("ch05", "best_step", """
        def best_step(f, fprime, x, hs):
            errors = [abs(central_difference(f, x, h) - fprime(x)) for h in hs]
            return int(np.argmin(errors))
        """, "best_step_worked_example", ["which is not one of the steps in hs"], set()),
    # ---------------------------------------------------------------- ch07
    "motion model without dt in x": ("ch07", "motion_model", """
        def motion_model(state, v, omega, dt):
            x, y, th = np.asarray(state, dtype=float)
            return np.array([x + v * np.cos(th), y + v * np.sin(th) * dt, th + omega * dt])
        """, "motion_model_random_inputs", ["state'[0] (x')"], {"F_jacobian_vs_own_motion_model"}),
    "F without dt": ("ch07", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = float(np.asarray(state, dtype=float)[2])
            return np.array([[1.0, 0.0, -v * np.sin(th)], [0.0, 1.0, v * np.cos(th)], [0.0, 0.0, 1.0]])
        """, "F_jacobian_random_points", ["F[0,2] = d x'/d theta", "column 2 (d/d theta)"], set()),
    "F with a sign slip": ("ch07", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = float(np.asarray(state, dtype=float)[2])
            return np.array([[1.0, 0.0, -v * np.sin(th) * dt], [0.0, 1.0, -v * np.cos(th) * dt], [0.0, 0.0, 1.0]])
        """, "F_worked_example", ["F[1,2] = d y'/d theta: got -0.173205, expected 0.173205"], set()),
    "F in the wrong column": ("ch07", "F_jacobian", """
        def F_jacobian(state, v, omega, dt):
            th = float(np.asarray(state, dtype=float)[2])
            return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-v * np.sin(th) * dt, v * np.cos(th) * dt, 1.0]])
        """, "F_jacobian_vs_own_motion_model", ["mistake is in F_jacobian"], set()),
    "covariance propagated as F^T P F": ("ch07", "propagate_covariance", """
        def propagate_covariance(P, F, Q=None):
            P, F = np.asarray(P, dtype=float), np.asarray(F, dtype=float)
            out = F.T @ P @ F
            return out if Q is None else out + np.asarray(Q, dtype=float)
        """, "propagate_random_matrices", ["propagate_covariance(P, F", "entries differ"], set()),
    "covariance without Q": ("ch07", "propagate_covariance", """
        def propagate_covariance(P, F, Q=None):
            P, F = np.asarray(P, dtype=float), np.asarray(F, dtype=float)
            return F @ P @ F.T
        """, "propagate_adds_q_only_when_given", ["propagate_covariance(P, F, Q)", "Q = [["], set()),
    "covariance as F P F": ("ch07", "propagate_covariance", """
        def propagate_covariance(P, F, Q=None):
            P, F = np.asarray(P, dtype=float), np.asarray(F, dtype=float)
            out = F @ P @ F
            return out if Q is None else out + np.asarray(Q, dtype=float)
        """, "propagate_result_is_symmetric_psd", ["is not symmetric"], set()),
    # ---------------------------------------------------------------- ch08
    "samples with variance sigma^4": ("ch08", "sample_positions", """
        def sample_positions(mean, sigma, n, rng):
            return np.asarray(mean, dtype=float) + sigma**2 * rng.standard_normal((int(n), 2))
        """, "sample_positions_statistics", ["sample variance of x", "standard errors"],
        {"mismatch_far_small_near_large", "mismatch_matches_simulation"}),
    "samples with the same noise on x and y": ("ch08", "sample_positions", """
        def sample_positions(mean, sigma, n, rng):
            noise = rng.standard_normal((int(n), 1))
            return np.asarray(mean, dtype=float) + sigma * np.hstack([noise, noise])
        """, "sample_positions_statistics", ["sample covariance of x and y"],
        {"mismatch_far_small_near_large", "mismatch_matches_simulation"}),
    "samples from a generator of their own": ("ch08", "sample_positions", """
        def sample_positions(mean, sigma, n, rng):
            return np.asarray(mean, dtype=float) + sigma * np.random.default_rng().standard_normal((int(n), 2))
        """, "sample_positions_shape_and_reproducible", ["same seed", "rng argument"], {"mismatch_reproducible"}),
    "bearings not unwrapped": ("ch08", "measure_samples", """
        def measure_samples(samples, ref_bearing):
            samples = np.asarray(samples, dtype=float)
            return np.column_stack([np.hypot(samples[:, 0], samples[:, 1]), np.arctan2(samples[:, 1], samples[:, 0])])
        """, "measure_samples_unwraps_around_ref_bearing", ["raw atan2 bearings", "(sample "],
        {"mismatch_matches_simulation"}),
    "bearings wrapped to [0, 2 pi)": ("ch08", "measure_samples", """
        def measure_samples(samples, ref_bearing):
            samples = np.asarray(samples, dtype=float)
            bearings = np.arctan2(samples[:, 1], samples[:, 0]) % (2 * np.pi)
            return np.column_stack([np.hypot(samples[:, 0], samples[:, 1]), bearings])
        """, "measure_samples_unwraps_around_ref_bearing", ["bearing): got"],
        {"mismatch_matches_simulation", "mismatch_far_small_near_large"}),
    "linearized covariance with sigma, not sigma^2": ("ch08", "linearized_measurement_cov", """
        def linearized_measurement_cov(x, y, sigma):
            H = H_jacobian(x, y)
            return float(sigma) * (H @ H.T)
        """, "linearized_cov_worked_example", ["S_lin[0,0] (range, range): got 0.8, expected 0.64"],
        {"mismatch_far_small_near_large", "mismatch_matches_simulation"}),
    "biased sample covariance": ("ch08", "sample_covariance", """
        def sample_covariance(z):
            z = np.asarray(z, dtype=float)
            centred = z - z.mean(axis=0)
            return centred.T @ centred / z.shape[0]
        """, "sample_covariance_matches_np_cov", ["biased covariance: divide by n - 1 = 4"], set()),
    "sample covariance of the rows": ("ch08", "sample_covariance", """
        def sample_covariance(z):
            return np.cov(np.asarray(z, dtype=float))
        """, "sample_covariance_matches_np_cov", ["shape (5, 5); expected shape (2, 2)"],
        {"mismatch_far_small_near_large", "mismatch_matches_simulation", "mismatch_reproducible"}),
    "mismatch without unwrapping": ("ch08", "linearization_mismatch", """
        def linearization_mismatch(x, y, sigma, n, seed):
            samples = sample_positions([x, y], sigma, n, np.random.default_rng(seed))
            z = np.column_stack([np.hypot(samples[:, 0], samples[:, 1]), np.arctan2(samples[:, 1], samples[:, 0])])
            s_lin = linearized_measurement_cov(x, y, sigma)
            return float(np.linalg.norm(sample_covariance(z) - s_lin) / np.linalg.norm(s_lin))
        """, "mismatch_matches_simulation", ["straddles +-pi", "standard deviations"], set()),
    "mismatch ignores the seed": ("ch08", "linearization_mismatch", """
        def linearization_mismatch(x, y, sigma, n, seed):
            samples = sample_positions([x, y], sigma, n, np.random.default_rng())
            z = measure_samples(samples, np.arctan2(y, x))
            s_lin = linearized_measurement_cov(x, y, sigma)
            return float(np.linalg.norm(sample_covariance(z) - s_lin) / np.linalg.norm(s_lin))
        """, "mismatch_reproducible", ["with the same seed"], set()),
    "EKF without bearing wrap": ("ch08", "ekf_update", """
        def ekf_update(x, P, z, R):
            x, P, z, R = (np.asarray(a, dtype=float) for a in (x, P, z, R))
            H = H_jacobian(x[0], x[1])
            S = H @ P @ H.T + R
            K = P @ H.T @ np.linalg.inv(S)
            return x + K @ (z - range_bearing(x[0], x[1])), (np.eye(2) - K @ H) @ P
        """, "ekf_update_wraps_bearing_innovation", ["x_new of ekf_update(", "innovation z - h(x) is not wrapped"], set()),
    "EKF gain with H instead of H^T": ("ch08", "ekf_update", """
        def ekf_update(x, P, z, R):
            x, P, z, R = (np.asarray(a, dtype=float) for a in (x, P, z, R))
            H = H_jacobian(x[0], x[1])
            y = z - range_bearing(x[0], x[1])
            y[1] = (y[1] + np.pi) % (2 * np.pi) - np.pi
            S = H @ P @ H.T + R
            K = P @ H @ np.linalg.inv(S)
            return x + K @ y, (np.eye(2) - K @ H) @ P
        """, "ekf_update_random_states", ["x_new of ekf_update(x=(3, 4)", "x_new[0] (x)"], set()),
    "EKF covariance grows": ("ch08", "ekf_update", """
        def ekf_update(x, P, z, R):
            x, P, z, R = (np.asarray(a, dtype=float) for a in (x, P, z, R))
            H = H_jacobian(x[0], x[1])
            y = z - range_bearing(x[0], x[1])
            y[1] = (y[1] + np.pi) % (2 * np.pi) - np.pi
            K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
            return x + K @ y, (np.eye(2) + K @ H) @ P @ (np.eye(2) + K @ H).T
        """, "ekf_update_shrinks_covariance", ["larger than P in some direction"], set()),
    "EKF Joseph form without K R K^T": ("ch08", "ekf_update", """
        def ekf_update(x, P, z, R):
            x, P, z, R = (np.asarray(a, dtype=float) for a in (x, P, z, R))
            H = H_jacobian(x[0], x[1])
            y = z - range_bearing(x[0], x[1])
            y[1] = (y[1] + np.pi) % (2 * np.pi) - np.pi
            K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
            I_KH = np.eye(2) - K @ H
            return x + K @ y, I_KH @ P @ I_KH.T
        """, "ekf_update_random_states", ["P_new of ekf_update(x=(3, 4)", "P_new[0,0] (x, x)"], set()),
    "EKF returns only x_new": ("ch08", "ekf_update", """
        def ekf_update(x, P, z, R):
            x, P, z, R = (np.asarray(a, dtype=float) for a in (x, P, z, R))
            H = H_jacobian(x[0], x[1])
            y = z - range_bearing(x[0], x[1])
            y[1] = (y[1] + np.pi) % (2 * np.pi) - np.pi
            return x + P @ H.T @ np.linalg.inv(H @ P @ H.T + R) @ y
        """, "ekf_update_random_states", ["expected the tuple (x_new, P_new)"], set()),
    # ---------------------------------------------------------------- ch09
    "gradient keeps integer x": ("ch09", "gradient_fd", """
        def gradient_fd(f, x, h=1e-5):
            x = np.asarray(x)
            grad = np.empty(x.size)
            for j in range(x.size):
                e = np.zeros_like(x)
                e[j] = h
                grad[j] = (float(f(x + e)) - float(f(x - e))) / (2 * h)
            return grad
        """, "gradient_fd_integer_input", ["convert x to float first"], set()),
    "gradient by forward differences": ("ch09", "gradient_fd", """
        def gradient_fd(f, x, h=1e-5):
            x = np.asarray(x, dtype=float)
            return np.array([(float(f(x + h * e)) - float(f(x))) / h for e in np.eye(x.size)])
        """, "gradient_fd_random_points", ["gradient[", "(d f/d "],
        {"hessian_fd_worked_example", "hessian_fd_random_points", "hessian_fd_is_symmetric",
         "hessian_fd_uses_the_step_as_given"}),
    "Hessian not symmetrised": ("ch09", "hessian_fd", """
        def hessian_fd(f, x, h=1e-4):
            return jacobian_fd(lambda v: gradient_fd(f, v, h), x, h)
        """, "hessian_fd_is_symmetric", ["is not exactly symmetric", "(J + J^T) / 2"], set()),
    "Hessian by a forward outer difference": ("ch09", "hessian_fd", """
        def hessian_fd(f, x, h=1e-4):
            x = np.asarray(x, dtype=float)
            g0 = gradient_fd(f, x, h)
            H = np.stack([(gradient_fd(f, x + h * e, h) - g0) / h for e in np.eye(x.size)], axis=1)
            return 0.5 * (H + H.T)
        """, "hessian_fd_random_points", ["Hessian[", "hessian_fd(saddle3_vec"], set()),
    "classify without symmetrising": ("ch09", "classify_critical_point", """
        def classify_critical_point(hessian):
            eigenvalues = np.linalg.eigvalsh(np.asarray(hessian, dtype=float))
            tolerance = 1e-8 * max(1.0, float(np.max(np.abs(eigenvalues))))
            positive, negative = np.any(eigenvalues > tolerance), np.any(eigenvalues < -tolerance)
            if positive and negative:
                return "saddle"
            if np.any(np.abs(eigenvalues) <= tolerance):
                return "degenerate"
            return "minimum" if positive else "maximum"
        """, "classify_symmetrises_its_input", ["symmetric part (A + A^T)/2"], set()),
    "classify with an exact zero test": ("ch09", "classify_critical_point", """
        def classify_critical_point(hessian):
            A = np.asarray(hessian, dtype=float)
            eigenvalues = np.linalg.eigvalsh(0.5 * (A + A.T))
            positive, negative = np.any(eigenvalues > 0), np.any(eigenvalues < 0)
            if positive and negative:
                return "saddle"
            if np.any(eigenvalues == 0):
                return "degenerate"
            return "minimum" if positive else "maximum"
        """, "classify_zero_threshold", ["expected 'degenerate'"], set()),
    "classify with an absolute threshold": ("ch09", "classify_critical_point", """
        def classify_critical_point(hessian):
            A = np.asarray(hessian, dtype=float)
            eigenvalues = np.linalg.eigvalsh(0.5 * (A + A.T))
            positive, negative = np.any(eigenvalues > 1e-8), np.any(eigenvalues < -1e-8)
            if positive and negative:
                return "saddle"
            if np.any(np.abs(eigenvalues) <= 1e-8):
                return "degenerate"
            return "minimum" if positive else "maximum"
        """, "classify_zero_threshold", ["eigenvalues 1e+03, 5e-06", "expected 'degenerate'"], set()),
    "classify: a zero eigenvalue beats mixed signs": ("ch09", "classify_critical_point", """
        def classify_critical_point(hessian):
            A = np.asarray(hessian, dtype=float)
            eigenvalues = np.linalg.eigvalsh(0.5 * (A + A.T))
            tolerance = 1e-8 * max(1.0, float(np.max(np.abs(eigenvalues))))
            if np.any(np.abs(eigenvalues) <= tolerance):
                return "degenerate"
            if np.any(eigenvalues > 0) and np.any(eigenvalues < 0):
                return "saddle"
            return "minimum" if eigenvalues[0] > 0 else "maximum"
        """, "classify_all_kinds", ["returned 'degenerate'; expected 'saddle'"], set()),
    "classify capitalised": ("ch09", "classify_critical_point", """
        def classify_critical_point(hessian):
            A = np.asarray(hessian, dtype=float)
            eigenvalues = np.linalg.eigvalsh(0.5 * (A + A.T))
            if eigenvalues.min() < 0 < eigenvalues.max():
                return "Saddle"
            return "minimum"
        """, "classify_worked_example", ["returned 'Saddle'; expected 'saddle' (exactly, in lower case"], set()),
}


@pytest.mark.parametrize("name", first_of_each(MUTANTS, lambda name: MUTANTS[name][0]))
def test_a_realistic_mistake_fails_the_check_aimed_at_it(submission_factory, name):
    chapter_id, function, source, target, words, collateral = MUTANTS[name]
    module = MODULES[chapter_id]
    root = submission_factory({module: replace_function(module, function, source)})
    chapter = grade_code(root, [chapter_id]).chapters[0]
    assert not chapter.problems, chapter.problems
    checks = checks_by_id(chapter)
    aimed = checks[target]
    assert aimed.function == function
    assert aimed.status == Status.FAIL, (aimed.status, aimed.message)
    for word in words:
        assert word in f"{aimed.message}\n{aimed.help}", aimed.message  # what is wrong, or the hint
    for check in chapter.checks:
        if check.function != function and check.id not in collateral:
            assert check.status == Status.PASS, (check.id, check.message)
