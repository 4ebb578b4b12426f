"""The mistakes a function that samples shows (grader.checks.sampling): by its generator (unseeded, or one of the
learner's own with a fixed seed) and by its cloud's moments and shape (uniform draws, sigma^2 as the scale, both
coordinates from one draw), named on the submissions that make them."""

from __future__ import annotations

import numpy as np
import pytest

from grader.checks.sampling import draws_mistake
from grader.model import Status
from tests.support import build_submission, grade_code, replace_function

DRAWS = {
    "uniform draws": ("sample_positions_statistics", """
        def sample_positions(mean, sigma, n, rng):
            return np.asarray(mean, dtype=float) + sigma * rng.uniform(-1.0, 1.0, (n, 2))
        """),
    "variance as the scale": ("sample_positions_statistics", """
        def sample_positions(mean, sigma, n, rng):
            return rng.normal(mean, sigma ** 2, size=(n, 2))
        """),
    "one draw for both coordinates": ("sample_positions_statistics", """
        def sample_positions(mean, sigma, n, rng):
            e = rng.standard_normal(n)
            return np.column_stack([mean[0] + sigma * e, mean[1] + sigma * e])
        """),
    "unseeded generator": ("sample_positions_shape_and_reproducible", """
        def sample_positions(mean, sigma, n, rng):
            return np.asarray(mean, dtype=float) + sigma * np.random.standard_normal((n, 2))
        """),
    "a generator of your own": ("sample_positions_shape_and_reproducible", """
        def sample_positions(mean, sigma, n, rng):
            own = np.random.default_rng(0)
            return np.asarray(mean, dtype=float) + sigma * own.standard_normal((n, 2))
        """),
}


@pytest.mark.parametrize("name", list(DRAWS))
def test_a_sampling_mistake_is_named(tmp_path, name):
    check_id, source = DRAWS[name]
    root = build_submission(tmp_path / "slip", {"ch08_lab": replace_function("ch08_lab", "sample_positions", source)})
    check = next(c for c in grade_code(root, ["ch08"]).chapters[0].checks if c.id == check_id)
    assert check.status == Status.FAIL and check.mistake == name, (check.mistake, check.message)


def test_right_draws_show_no_mistake():
    rng = np.random.default_rng(11)
    clouds = []
    for sigma in (0.4, 1.7, 0.6):
        mean = rng.uniform(-5, 5, 2)
        clouds.append((mean + sigma * rng.standard_normal((4000, 2)), mean, sigma))
    assert draws_mistake(clouds) is None
    assert draws_mistake([(m + s * rng.uniform(-1, 1, (4000, 2)), m, s) for _, m, s in clouds]).name == "uniform draws"


def test_a_cloud_without_spread_is_no_uniform_draw():
    mean = np.array([3.0, -1.0])
    clouds = [(np.tile(mean, (4000, 1)), mean, sigma) for sigma in (0.4, 1.7)]
    assert draws_mistake(clouds).name == "no spread"
