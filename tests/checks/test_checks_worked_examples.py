"""The contract's worked examples hold for the reference solutions, to the digits shown there;
the stubs match the solutions' signatures and raise NotImplementedError."""

from __future__ import annotations

import importlib
import inspect
import math

import numpy as np
import pytest

from grader.chapters import CHAPTERS

PI = math.pi
sqrt_prime = lambda x: 0.5 / np.sqrt(x)  # noqa: E731


def ref(module):
    return importlib.import_module(f"solutions.{module}")


def close(got, expected, digits):
    np.testing.assert_allclose(np.asarray(got, dtype=float), np.asarray(expected, dtype=float),
                               rtol=0, atol=0.5 * 10.0**-digits)


def test_ch00():
    m = ref("ch00_range_sensor")
    assert m.range_reading(3, 4) == 5
    assert m.superposition_gap((3, 0), (0, 4)) == -2
    assert abs(m.mean_shift((3, 4), 1.0, 100000, 7) - 0.10) < 0.01


def test_ch01():
    m = ref("ch01_tangent_line")
    close(m.tangent_line(np.sqrt, sqrt_prime, 4, 5), 2.25, 12)
    close(m.linearization_error(np.sqrt, sqrt_prime, 4, np.array([4.5, 5, 6, 8])),
          [0.003680, 0.013932, 0.050510, 0.171573], 6)
    close(m.taylor_error_estimate(lambda x: -0.25 * x**-1.5, 4, 1), 1 / 64, 12)


def test_ch02():
    m = ref("ch02_gradient")
    assert m.example_f(1, 2) == 3
    close(m.example_gradient(1, 2), [4, 1], 12)
    f = lambda v: v[0] ** 2 + v[0] * v[1]  # noqa: E731
    grad = lambda v: np.array([2 * v[0] + v[1], v[0]])  # noqa: E731
    close(m.tangent_plane(f, grad, (1, 2), (1.1, 2.1)), 3.50, 2)
    for x, y in [(1, 2), (-0.3, 0.7)]:
        assert abs(np.dot(m.contour_direction(x, y), m.bowl_gradient(x, y))) < 1e-12
    with pytest.raises(ValueError):
        m.contour_direction(0, 0)


def test_ch03():
    m = ref("ch03_jacobian")
    close(m.polar_to_cartesian(4, PI / 3), [2, 3.4641], 4)
    close(m.polar_to_cartesian_jacobian(4, PI / 3), [[0.5, -3.4641], [0.8660, 2.0]], 4)
    close(m.area_scale(4, PI / 3), 4, 12)


def test_ch04():
    m = ref("ch04_chain_rule")
    close(m.g_jacobian((2, 3.4641)), [[4, 1], [3.4641, 2]], 12)
    close(m.pipeline_jacobian(4, PI / 3), [[2.866, -11.856], [3.464, -8.000]], 3)


def test_ch05():
    m = ref("ch05_finite_differences")
    polar = ref("ch03_jacobian").polar_to_cartesian
    assert abs(m.central_difference(np.sin, 1.0, 1e-5) - math.cos(1)) < 1e-10
    close(m.jacobian_fd(lambda v: polar(*v), (4, PI / 3)), [[0.5, -3.4641016], [0.8660254, 2.0]], 6)
    step = m.best_step(np.sin, np.cos, 1.0, 10.0 ** -np.arange(16, 0, -1))
    # numpy's power may round 10.0 ** -5 to 9.999999999999999e-06: compare to the last bit or so
    assert any(math.isclose(step, h, rel_tol=1e-12) for h in (1e-5, 1e-6)), step


def test_ch06():
    m = ref("ch06_measurement")
    close(m.range_bearing(3, 4), [5, 0.9273], 4)
    close(m.H_jacobian(3, 4), [[0.6, 0.8], [-0.16, 0.12]], 12)
    close(m.measurement_covariance(3, 4, 1.0), np.diag([1, 0.04]), 12)
    for function in (m.H_jacobian, lambda x, y: m.measurement_covariance(x, y, 1.0)):
        with pytest.raises(ValueError):
            function(0, 0)


def test_ch07():
    m = ref("ch07_dynamics")
    F = m.F_jacobian((0, 0, PI / 6), 2.0, 0.5, 0.1)
    close([F[0, 2], F[1, 2]], [-0.1, 0.1732], 4)
    close(m.propagate_covariance(np.diag([0.04, 0.04, 0.01]), F),
          [[0.0401, -0.000173, -0.001], [-0.000173, 0.0403, 0.001732], [-0.001, 0.001732, 0.01]], 6)


def test_ch08():
    m = ref("ch08_lab")
    close(m.linearized_measurement_cov(3, 4, 0.8), np.diag([0.64, 0.0256]), 12)
    z = np.random.default_rng(3).standard_normal((50, 2))
    close(m.sample_covariance(z), np.cov(z.T), 12)
    assert m.linearization_mismatch(3, 4, 0.8, 5000, 11) < 0.1
    assert m.linearization_mismatch(0.3, 0.2, 0.8, 5000, 11) > 0.4
    with pytest.raises(ValueError):
        m.ekf_update((0, 0), np.eye(2), (1, 0), np.eye(2))


def test_ch09():
    m = ref("ch09_choose_your_tool")
    close(m.hessian_fd(lambda v: v[0] ** 2 + v[0] * v[1], (1, 2)), [[2, 1], [1, 0]], 5)
    assert m.classify_critical_point([[2, 1], [1, 0]]) == "saddle"


def _public_functions(module):
    return {name: f for name, f in vars(module).items()
            if inspect.isfunction(f) and not name.startswith("_") and f.__module__ == module.__name__}


@pytest.mark.parametrize("info", CHAPTERS, ids=lambda c: c.id)
def test_stub_matches_solution_signatures_and_raises_not_implemented(info):
    stub = importlib.import_module(f"exercises.{info.module}")
    solution = importlib.import_module(f"solutions.{info.module}")
    stubs, solutions = _public_functions(stub), _public_functions(solution)
    assert set(stubs) == set(solutions)
    assert stub.__doc__ and "grade" in stub.__doc__
    for name, function in stubs.items():
        assert list(inspect.signature(function).parameters.values()) == \
            list(inspect.signature(solutions[name]).parameters.values()), name
        doc = function.__doc__ or ""
        assert "Returns" in doc and "Example" in doc, f"{name}'s docstring lacks Returns/Example"
        arguments = [None] * sum(p.default is inspect.Parameter.empty
                                 for p in inspect.signature(function).parameters.values())
        with pytest.raises(NotImplementedError):
            function(*arguments)


def test_beyond_the_worked_examples():
    """The contract's checked point of each map beyond the worked examples, and its singular points."""
    ch02, ch03, ch04 = ref("ch02_gradient"), ref("ch03_jacobian"), ref("ch04_chain_rule")
    ch06, ch07 = ref("ch06_measurement"), ref("ch07_dynamics")
    close(ch02.planner_cost(0, 1, (2, 1)), 1.25, 12)
    close(ch02.planner_cost_gradient(0, 1, (2, 1)), [0.25, 2], 12)
    close(ch03.spherical_to_cartesian(2, 0, 0), [2, 0, 0], 12)
    close(ch03.spherical_to_cartesian_jacobian(2, 0, 0), np.diag([1, 2, 2]), 12)
    close(ch03.volume_scale(2, 0, 0), 4, 12)
    close(ch03.volume_scale(1.5, 0.4, -0.9), 1.5**2 * math.cos(-0.9), 12)
    pose = (1, 2, PI / 2)
    close(ch04.lidar_to_world(1, 0, pose), [1, 3], 12)
    close(ch04.lidar_to_world_jacobian(1, 0, pose), [[0, -1], [1, 0]], 12)
    close(ch04.lidar_pose_jacobian(1, 0, pose), [[1, 0, -1], [0, 1, 0]], 12)
    close(ch06.range_bearing_elevation(3, 4, 0), [5, 0.9273, 0], 4)
    close(ch06.H3_jacobian(1, 0, 1), [[0.7071, 0, 0.7071], [0, 1, 0], [-0.5, 0, 0.5]], 4)
    close(ch07.bicycle_control_jacobian((0, 0, 0), 2, 0, 1, 0.1), [[0.1, 0], [0, 0], [0, 0.2]], 12)
    Q = ch07.control_noise_covariance((0.3, -1, 0.7), 1.5, 0.4, 2.0, 0.2, 0.3, 0.05)
    close(Q, Q.T, 15)
    assert np.linalg.matrix_rank(Q) <= 2
    for function, args in ((ch02.planner_cost, (2, 1, (2, 1))), (ch02.planner_cost_gradient, (2, 1, (2, 1))),
                           (ch06.H3_jacobian, (0, 0, 1.5)), (ch06.H3_jacobian, (0, 0, 0))):
        with pytest.raises(ValueError):
            function(*args)
