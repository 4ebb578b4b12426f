"""The catalogue of callables handed to learner functions runs beside learner code, which can read and
call all of it: no entry may compute an exercise's function or derivative. Its twins of the lesson's
maps agree with them only where the worked examples use them."""

from __future__ import annotations

import numpy as np
import pytest

from grader.catalogue import CALLABLES
from solutions import (
    ch00_range_sensor,
    ch02_gradient,
    ch03_jacobian,
    ch04_chain_rule,
    ch06_measurement,
    ch07_dynamics,
)

# every exercise function of one or two numbers or of one vector, as a function of one vector
EXERCISES = {
    "range_reading": lambda v: ch00_range_sensor.range_reading(*v[:2]),
    "example_f": lambda v: ch02_gradient.example_f(*v[:2]),
    "example_gradient": lambda v: ch02_gradient.example_gradient(*v[:2]),
    "bowl_gradient": lambda v: ch02_gradient.bowl_gradient(*v[:2]),
    "polar_to_cartesian": lambda v: ch03_jacobian.polar_to_cartesian(*v[:2]),
    "polar_to_cartesian_jacobian": lambda v: ch03_jacobian.polar_to_cartesian_jacobian(*v[:2]),
    "area_scale": lambda v: ch03_jacobian.area_scale(*v[:2]),
    "g_stage": lambda v: ch04_chain_rule.g_stage(v[:2]),
    "g_jacobian": lambda v: ch04_chain_rule.g_jacobian(v[:2]),
    "pipeline_jacobian": lambda v: ch04_chain_rule.pipeline_jacobian(*v[:2]),
    "range_bearing": lambda v: ch06_measurement.range_bearing(*v[:2]),
    "H_jacobian": lambda v: ch06_measurement.H_jacobian(*v[:2]),
    "motion_model": lambda v: ch07_dynamics.motion_model(v[:3], 1.3, 0.4, 0.2),
    "F_jacobian": lambda v: ch07_dynamics.F_jacobian(v[:3], 1.3, 0.4, 0.2),
    "planner_cost": lambda v: ch02_gradient.planner_cost(*v[:2], (2.9, -0.4)),
    "planner_cost_gradient": lambda v: ch02_gradient.planner_cost_gradient(*v[:2], (2.9, -0.4)),
    "spherical_to_cartesian": lambda v: ch03_jacobian.spherical_to_cartesian(*v[:3]),
    "spherical_to_cartesian_jacobian": lambda v: ch03_jacobian.spherical_to_cartesian_jacobian(*v[:3]),
    "volume_scale": lambda v: ch03_jacobian.volume_scale(*v[:3]),
    "lidar_to_world": lambda v: ch04_chain_rule.lidar_to_world(*v[:2], (0.5, -1.0, 0.7)),
    "lidar_to_world_jacobian": lambda v: ch04_chain_rule.lidar_to_world_jacobian(*v[:2], (0.5, -1.0, 0.7)),
    "lidar_pose_jacobian": lambda v: ch04_chain_rule.lidar_pose_jacobian(1.2, 0.3, v[:3]),
    "range_bearing_elevation": lambda v: ch06_measurement.range_bearing_elevation(*v[:3]),
    "H3_jacobian": lambda v: ch06_measurement.H3_jacobian(*v[:3]),
    "bicycle_model": lambda v: ch07_dynamics.bicycle_model(v[:3], 1.3, 0.4, 2.5, 0.2),
    "bicycle_control_jacobian": lambda v: ch07_dynamics.bicycle_control_jacobian(v[:3], 1.3, 0.4, 2.5, 0.2),
}


def _values(function, points):
    out = []
    for p in points:
        try:
            out.append(np.asarray(function(p), dtype=float))
        except Exception:  # noqa: BLE001 - a callable that cannot take this point is not this exercise
            return None
    return out


@pytest.mark.parametrize("name", sorted(CALLABLES))
def test_no_catalogue_entry_computes_an_exercise(name):
    rng = np.random.default_rng(7)
    callable_ = CALLABLES[name]
    for size in (1, 2, 3):
        points = [rng.uniform(0.6, 2.4, size) for _ in range(5)]
        mine = _values(callable_, points)
        if mine is None:
            continue
        for exercise, function in EXERCISES.items():
            theirs = _values(function, [np.resize(p, 3) for p in points]) if size < 3 else _values(function, points)
            if theirs is None or any(a.shape != b.shape for a, b in zip(mine, theirs)):
                continue
            assert not all(np.allclose(a, b, rtol=1e-6, atol=1e-9) for a, b in zip(mine, theirs)), (name, exercise)


def test_the_twins_agree_with_the_lesson_maps_only_at_the_worked_examples():
    point = np.array([4.0, np.pi / 3])
    polar = ch03_jacobian.polar_to_cartesian
    assert np.allclose(CALLABLES["polar_twin_vec"](point), polar(*point))
    elsewhere = point + np.array([0.7, -0.4])
    assert not np.allclose(CALLABLES["polar_twin_vec"](elsewhere), polar(*elsewhere), atol=1e-3)
    a = np.array([1.0, 2.0])
    assert CALLABLES["plane_twin_vec"](a) == ch02_gradient.example_f(*a)
    assert np.allclose(CALLABLES["plane_twin_grad_vec"](a), ch02_gradient.example_gradient(*a))
    assert not np.isclose(CALLABLES["plane_twin_vec"](a + 1), ch02_gradient.example_f(*(a + 1)))
