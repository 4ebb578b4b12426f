"""Blame once: a wrong forward function costs its own points, never its derivative's; a function built
on a learner's wrong helper points at the helper; and a submission in a private folder (0700, as
`mktemp -d` makes) grades normally, because its files travel to the sandboxed child in the request."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

from grader import boundary
from grader.model import Status
from tests.support import (
    build_submission,
    checks_by_id,
    grade_checks,
    grade_code,
    replace_function,
)

WRONG_RANGE_BEARING = """
def range_bearing(x, y):
    return np.array([np.hypot(x, y), np.arctan2(x, y)], dtype=float)
"""
BROKEN_RANGE_BEARING = """
def range_bearing(x, y):
    raise RuntimeError("half written")
"""


@pytest.mark.parametrize("forward", [WRONG_RANGE_BEARING, BROKEN_RANGE_BEARING], ids=["wrong", "raises"])
def test_a_wrong_forward_function_costs_its_derivative_nothing(tmp_path, forward):
    root = build_submission(tmp_path, {"ch06_measurement": replace_function("ch06_measurement", "range_bearing",
                                                                            forward)})
    checks = grade_checks(root, "ch06")
    own = checks["H_jacobian_vs_own_range_bearing"]
    assert own.status == Status.SKIP and own.points == own.max_points, (own.status, own.message)
    assert "no points lost" in own.message and "fix range_bearing first" in own.message.replace("Fix", "fix")
    h_checks = [c for c in checks.values() if c.function == "H_jacobian"]
    assert sum(c.points for c in h_checks) == sum(c.max_points for c in h_checks)  # H is right: all its points
    assert any(c.status == Status.FAIL for c in checks.values() if c.function == "range_bearing")


def test_a_function_built_on_a_wrong_helper_points_at_the_helper(tmp_path):
    forward_gradient = """
    def gradient_fd(f, x, h=1e-5):
        x = np.asarray(x, dtype=float)
        base = float(f(x))
        out = np.zeros(x.size)
        for j in range(x.size):
            e = np.zeros_like(x)
            e[j] = h
            out[j] = (f(x + e) - base) / h
        return out
    """
    root = build_submission(tmp_path, {"ch09_choose_your_tool": replace_function("ch09_choose_your_tool", "gradient_fd",
                                                                                 forward_gradient)})
    report = grade_code(root, ["ch05", "ch09"])
    ch09 = checks_by_id(report.chapters[1])
    hessian = [c for c in ch09.values() if c.function == "hessian_fd" and c.status == Status.FAIL]
    assert hessian, "the reference hessian_fd uses gradient_fd: it must fail with it"
    assert all(c.message.startswith("hessian_fd usually builds on your gradient_fd, which fails its own checks")
               for c in hessian), [c.message[:120] for c in hessian]
    untouched = checks_by_id(report.chapters[0])  # ch05's jacobian_fd is right: nothing points at it
    assert all(c.status == Status.PASS for c in untouched.values())


@pytest.mark.skipif(os.geteuid() != 0, reason="a folder only root can read needs root to grade from")
def test_a_submission_in_a_private_folder_grades_normally():
    private = Path(tempfile.mkdtemp(prefix="private-"))  # 0700, as mktemp -d makes it
    try:
        assert oct(private.stat().st_mode & 0o777) == "0o700"
        root = build_submission(private / "work")
        os.chmod(private / "work", 0o700)
        chosen = boundary.choose("auto")
        assert chosen.sandboxed or not os.environ.get("CI"), "CI must have bubblewrap"
        report = grade_code(root, ["ch06"], boundary=chosen)
        assert report.chapters[0].score == report.chapters[0].max_score, report.chapters[0].problems
    finally:
        import shutil

        shutil.rmtree(private, ignore_errors=True)
