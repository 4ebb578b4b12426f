"""The finite-difference tolerance never fails a right derivative and always fails a sign slip,
transpose or missing term, on every derivative the grader checks (grader/checks/derivatives.py)."""

from __future__ import annotations

import numpy as np
import pytest

from grader import checks
from grader.chapters import CHAPTERS
from grader.checks import derivatives
from grader.checks.derivatives import FD_ATOL, FD_RTOL, MIN_ENTRY, central_difference
from grader.judging import expected

for _info in CHAPTERS:
    checks.load(_info.id)
DERIVATIVES = list(derivatives.REGISTERED)
SEEDS = range(25)


def _cases(d):
    for seed in SEEDS:
        yield from d.cases(np.random.default_rng(seed))


def _tolerance(value):
    return FD_ATOL + FD_RTOL * np.abs(value)


@pytest.fixture(autouse=True)
def live_reference():
    """The references answer as they do while a check plans (grader.judging.expected)."""
    with expected.using(expected.Live()), expected.planning("tests", "tolerances", 0):
        yield


def test_every_analytic_derivative_is_registered():
    names = {d.jacobian for d in DERIVATIVES}
    assert {"example_gradient", "polar_to_cartesian_jacobian", "g_jacobian", "H_jacobian", "F_jacobian"} <= names


@pytest.mark.parametrize("d", DERIVATIVES, ids=lambda d: d.jacobian)
def test_right_derivative_is_far_inside_the_tolerance(d):
    for point, extra in _cases(d):
        exact = np.asarray(d.reference_jacobian(point, extra), dtype=float)
        fd = central_difference(lambda p: d.reference_forward(p, extra), point)
        # a correct answer differs from the central difference by at most a tenth of the tolerance
        assert np.all(np.abs(fd - exact) <= 0.1 * _tolerance(fd)), (d.jacobian, point)


@pytest.mark.parametrize("d", DERIVATIVES, ids=lambda d: d.jacobian)
def test_sign_slip_missing_term_and_transpose_always_fail(d):
    for point, extra in _cases(d):
        exact = np.asarray(d.reference_jacobian(point, extra), dtype=float)
        fd = central_difference(lambda p: d.reference_forward(p, extra), point)
        limit = _tolerance(fd)
        for index in zip(*np.nonzero(np.abs(exact) > 1e-12)):
            assert abs(exact[index]) >= MIN_ENTRY, (d.jacobian, point, index)
            slipped = exact.copy()
            slipped[index] = -slipped[index]  # sign slip
            missing = exact.copy()
            missing[index] = 0.0  # a missing term (the whole entry)
            for mutant in (slipped, missing):
                assert np.any(np.abs(mutant - fd) > 100 * limit), (d.jacobian, point, index)
        if exact.ndim == 2 and exact.shape[0] == exact.shape[1] and not np.allclose(exact, exact.T):
            assert np.any(np.abs(exact.T - fd) > 100 * limit), (d.jacobian, point)


@pytest.mark.parametrize("d", DERIVATIVES, ids=lambda d: d.jacobian)
def test_square_jacobians_are_never_symmetric_at_the_sampled_points(d):
    """So a transposed answer can never hide: checked wherever the matrix is square."""
    for point, extra in _cases(d):
        exact = np.asarray(d.reference_jacobian(point, extra), dtype=float)
        if exact.ndim == 2 and exact.shape[0] == exact.shape[1]:
            assert np.max(np.abs(exact - exact.T)) >= MIN_ENTRY, (d.jacobian, point)
