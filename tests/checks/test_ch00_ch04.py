"""The checks of chapters 0-4 through the real grader and real child processes: the reference
solutions get full marks, the stubs get zero, and each realistic mistake fails the check aimed at it."""

from __future__ import annotations

import numpy as np
import pytest

from grader import checks as check_registry
from grader.chapters import BY_ID
from grader.model import Status
from solutions.oracle.ch00 import rice_moments
from tests.support import (
    BEYOND_THE_WORKED_EXAMPLES,
    checks_by_id,
    first_of_each,
    grade_code,
    replace_function,
)

CHAPTERS = ["ch00", "ch01", "ch02", "ch03", "ch04"]
MODULES = {c: BY_ID[c].module for c in CHAPTERS}


def test_chapter_sizes_follow_the_guide():
    """The worked examples' functions keep the guide's size; the maps beyond them and the exact-derivative
    checks come on top, up to 6 points per map."""
    for chapter_id in CHAPTERS:
        chapter = check_registry.load(chapter_id)
        beyond = BEYOND_THE_WORKED_EXAMPLES.get(chapter_id, ())
        worked = [c for c in chapter.checks if c.function not in beyond and not c.exact_derivative]
        assert 10 <= sum(c.points for c in worked) <= 16, chapter_id
        assert sum(c.points for c in chapter.checks if c.function in beyond) <= 6 * len(beyond), chapter_id
        assert all(1 <= c.points <= 2 for c in chapter.checks), chapter_id


def test_rice_moments_match_a_large_sample():
    rng = np.random.default_rng(7)
    for r, sigma in [(5.0, 1.0), (2.0, 1.6), (3.0, 0.6)]:
        mean, variance = rice_moments(r, sigma)
        ranges = np.hypot(r + sigma * rng.standard_normal(400_000), sigma * rng.standard_normal(400_000))
        assert abs(mean - ranges.mean()) < 5 * np.sqrt(variance / ranges.size)
        assert variance == pytest.approx(ranges.var(), rel=0.02)
    assert rice_moments(5.0, 1.0)[0] - 5.0 == pytest.approx(0.1, abs=0.002)  # about sigma^2 / 2r


# the reference's lidar_to_world_jacobian is built with compose_jacobian, so it fails with a wrong one
LIDAR_JACOBIAN_CHECKS = ("lidar_to_world_jacobian_worked_example", "lidar_to_world_jacobian_random_points",
                         "lidar_to_world_jacobian_vs_own_lidar_to_world", "lidar_to_world_jacobian_exact")

# (chapter, function, wrong source, the check aimed at it, words its message must contain,
#  checks of other functions that use the wrong one and so may fail with it)
MUTANTS = {
    "range without sqrt": ("ch00", "range_reading", """
        def range_reading(x, y):
            return float(x) ** 2 + float(y) ** 2
        """, "range_reading_worked_example", ["range_reading(3, 4): got 25, expected 5"],
        {"superposition_gap_worked_example", "superposition_gap_random_points", "mean_shift_worked_example",
         "mean_shift_random_inputs"}),
    "gap with the sign flipped": ("ch00", "superposition_gap", """
        def superposition_gap(p, q):
            p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
            return range_reading(*p) + range_reading(*q) - range_reading(*(p + q))
        """, "superposition_gap_worked_example", ["got 2, expected -2"], set()),
    "mean shift without minus range(mean)": ("ch00", "mean_shift", """
        def mean_shift(mean, sigma, n, seed):
            rng = np.random.default_rng(seed)
            samples = np.asarray(mean, dtype=float) + sigma * rng.standard_normal((int(n), 2))
            return float(np.mean(np.hypot(samples[:, 0], samples[:, 1])))
        """, "mean_shift_worked_example", ["mean_shift((3, 4), 1, 100000, seed=0)", "standard errors"], set()),
    "mean shift with variance sigma^4": ("ch00", "mean_shift", """
        def mean_shift(mean, sigma, n, seed):
            mean = np.asarray(mean, dtype=float)
            rng = np.random.default_rng(seed)
            samples = mean + sigma**2 * rng.standard_normal((int(n), 2))
            return float(np.mean(np.hypot(samples[:, 0], samples[:, 1])) - range_reading(*mean))
        """, "mean_shift_random_inputs", ["mean_shift(", "about sigma^2/(2r)"], set()),
    "mean shift ignores the seed": ("ch00", "mean_shift", """
        def mean_shift(mean, sigma, n, seed):
            mean = np.asarray(mean, dtype=float)
            rng = np.random.default_rng()
            samples = mean + sigma * rng.standard_normal((int(n), 2))
            return float(np.mean(np.hypot(samples[:, 0], samples[:, 1])) - range_reading(*mean))
        """, "mean_shift_reproducible", ["with the same seed", "np.random.default_rng(seed)"], set()),
    "tangent slope taken at x": ("ch01", "tangent_line", """
        def tangent_line(f, fprime, a, x):
            xs = np.asarray(x, dtype=float)
            return _out(f(a) + fprime(xs) * (xs - a), x)
        """, "tangent_line_worked_example", ["tangent_line(sqrt, sqrt_prime, a=4, x=5): got 2.22361, expected 2.25"],
        set()),
    "tangent slope with the sign flipped": ("ch01", "tangent_line", """
        def tangent_line(f, fprime, a, x):
            xs = np.asarray(x, dtype=float)
            return _out(f(a) - fprime(a) * (xs - a), x)
        """, "tangent_line_random_inputs", ["tangent_line(f=", "expected"], set()),
    "error without abs": ("ch01", "linearization_error", """
        def linearization_error(f, fprime, a, x):
            xs = np.asarray(x, dtype=float)
            return _out(f(xs) - (f(a) + fprime(a) * (xs - a)), x)
        """, "linearization_error_worked_example", ["error[3]: got -0.171573, expected 0.171573"], set()),
    "error of the constant, not the tangent": ("ch01", "linearization_error", """
        def linearization_error(f, fprime, a, x):
            xs = np.asarray(x, dtype=float)
            return _out(np.abs(f(xs) - f(a)), x)
        """, "linearization_error_grows_like_delta_squared", ["the log-log slope is", "should grow like delta^2"], set()),
    "Taylor estimate without the 1/2": ("ch01", "taylor_error_estimate", """
        def taylor_error_estimate(fsecond, a, delta):
            return float(np.abs(fsecond(a)) * delta**2)
        """, "taylor_error_estimate_matches_actual_error", ["vs the actual error of the tangent line"], set()),
    "Taylor estimate without abs": ("ch01", "taylor_error_estimate", """
        def taylor_error_estimate(fsecond, a, delta):
            return float(0.5 * fsecond(a) * delta**2)
        """, "taylor_error_estimate_worked_example", ["got -0.015625, expected 0.015625"], set()),
    "f missing its x y term": ("ch02", "example_f", """
        def example_f(x, y):
            return float(x) ** 2
        """, "example_f_worked_example", ["example_f(1, 2): got 1, expected 3"],
        {"example_gradient_vs_own_example_f"}),
    "gradient entries swapped": ("ch02", "example_gradient", """
        def example_gradient(x, y):
            return np.array([float(x), 2 * float(x) + float(y)])
        """, "example_gradient_random_points", ["grad f[0] (d f/d x)", "column 0 (d/d x)"], set()),
    "tangent plane with grad at x": ("ch02", "tangent_plane", """
        def tangent_plane(f, grad, a, x):
            a, x = np.asarray(a, dtype=float), np.asarray(x, dtype=float)
            return float(f(a) + np.dot(grad(x), x - a))
        """, "tangent_plane_worked_example", ["got 3.52, expected 3.5"], set()),
    "bowl gradient coefficients swapped": ("ch02", "bowl_gradient", """
        def bowl_gradient(x, y):
            x, y = float(x), float(y)
            return np.array([0.5 * x + 2 * y, 2 * x + 0.5 * y])
        """, "bowl_gradient_random_points", ["grad g[0] (d g/d x)", "bowl_gradient("],
        {"contour_direction_is_unit_and_perpendicular"}),
    "contour along the gradient": ("ch02", "contour_direction", """
        def contour_direction(x, y):
            g = bowl_gradient(x, y)
            if not g.any():
                raise ValueError("no direction at the origin")
            return g / np.linalg.norm(g)
        """, "contour_direction_is_unit_and_perpendicular", ["contour test[1] (t . grad g / |grad g|): got 1"],
        set()),
    "contour without the origin check": ("ch02", "contour_direction", """
        def contour_direction(x, y):
            gx, gy = bowl_gradient(x, y)
            return np.array([-gy, gx]) / np.hypot(gx, gy)
        """, "contour_direction_raises_at_origin", ["expected it to raise ValueError"], set()),
    "polar in degrees": ("ch03", "polar_to_cartesian", """
        def polar_to_cartesian(r, theta):
            t = np.deg2rad(float(theta))
            return float(r) * np.array([np.cos(t), np.sin(t)])
        """, "polar_random_points", ["p[0] (x)", "polar_to_cartesian("],
        {"polar_to_cartesian_jacobian_vs_own_polar_to_cartesian"}),
    "J transposed": ("ch03", "polar_to_cartesian_jacobian", """
        def polar_to_cartesian_jacobian(r, theta):
            r, theta = float(r), float(theta)
            c, s = np.cos(theta), np.sin(theta)
            return np.array([[c, s], [-r * s, r * c]])
        """, "polar_to_cartesian_jacobian_random_points", ["J[0,1] = d x/d theta", "J[1,0] = d y/d r"], set()),
    "J missing r in the theta column": ("ch03", "polar_to_cartesian_jacobian", """
        def polar_to_cartesian_jacobian(r, theta):
            c, s = np.cos(float(theta)), np.sin(float(theta))
            return np.array([[c, -s], [s, c]])
        """, "polar_to_cartesian_jacobian_vs_own_polar_to_cartesian",
        ["column 1 (d/d theta)", "mistake is in polar_to_cartesian_jacobian"],
        {"area_scale_worked_example", "area_scale_is_r", "area_scale_is_det_of_your_jacobian"}),
    "area scale unsigned": ("ch03", "area_scale", """
        def area_scale(r, theta):
            return abs(float(np.linalg.det(polar_to_cartesian_jacobian(r, theta))))
        """, "area_scale_is_r", ["area_scale(-"], set()),
    "g stage missing + u2": ("ch04", "g_stage", """
        def g_stage(u):
            u1, u2 = np.asarray(u, dtype=float)
            return np.array([u1**2, u1 * u2])
        """, "g_stage_random_points", ["g[0] (u1^2 + u2)"],
        {"g_jacobian_vs_own_g_stage", "pipeline_jacobian_vs_own_g_stage"}),
    "Jg transposed": ("ch04", "g_jacobian", """
        def g_jacobian(u):
            u1, u2 = np.asarray(u, dtype=float)
            return np.array([[2 * u1, u2], [1.0, u1]])
        """, "g_jacobian_random_points", ["Jg[0,1] = d g1/d u2"],
        {"pipeline_jacobian_worked_example", "pipeline_jacobian_random_points", "pipeline_jacobian_vs_own_g_stage",
         "pipeline_jacobian_exact"}),
    "chain rule in the wrong order": ("ch04", "compose_jacobian", """
        def compose_jacobian(f, jac_f, jac_g, x):
            x = np.asarray(x, dtype=float)
            return np.asarray(jac_f(x)) @ np.asarray(jac_g(f(x)))
        """, "compose_jacobian_order_and_point", ["wrong order"],
        {"pipeline_jacobian_worked_example", "pipeline_jacobian_random_points", "pipeline_jacobian_vs_own_g_stage",
         "pipeline_jacobian_exact", *LIDAR_JACOBIAN_CHECKS}),
    "Jg taken at x, not f(x)": ("ch04", "compose_jacobian", """
        def compose_jacobian(f, jac_f, jac_g, x):
            x = np.asarray(x, dtype=float)
            return np.asarray(jac_g(x)) @ np.asarray(jac_f(x))
        """, "compose_jacobian_order_and_point", ["the outer Jacobian is taken at x"],
        {"pipeline_jacobian_worked_example", "pipeline_jacobian_random_points", "pipeline_jacobian_vs_own_g_stage",
         "pipeline_jacobian_exact", *LIDAR_JACOBIAN_CHECKS}),
    "pipeline without the inner Jacobian": ("ch04", "pipeline_jacobian", """
        def pipeline_jacobian(r, theta):
            return g_jacobian(polar_to_cartesian(r, theta))
        """, "pipeline_jacobian_worked_example", ["J[0,1] = d g1/d theta"], set()),
}


@pytest.mark.parametrize("name", first_of_each(MUTANTS, lambda name: MUTANTS[name][0]))
def test_a_realistic_mistake_fails_the_check_aimed_at_it(submission_factory, name):
    chapter_id, function, source, target, words, collateral = MUTANTS[name]
    module = MODULES[chapter_id]
    root = submission_factory({module: replace_function(module, function, source)})
    chapter = grade_code(root, [chapter_id]).chapters[0]
    checks = checks_by_id(chapter)
    aimed = checks[target]
    assert aimed.function == function or target in collateral
    assert aimed.status == Status.FAIL, (aimed.status, aimed.message)
    for word in words:
        assert word in f"{aimed.message}\n{aimed.help}", aimed.message  # what is wrong, or the hint
    for check in chapter.checks:
        if check.function != function and check.id not in collateral:
            assert check.status == Status.PASS, (check.id, check.message)
